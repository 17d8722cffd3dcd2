-- 004: the 'rollback' job type (an admin job that makes an older prior version current again
-- as a new version). SQLite cannot alter a CHECK constraint, so jobs is rebuilt with the same
-- columns; job_tiles, which references it, is rebuilt beside it so that no row is ever
-- without its job (foreign keys stay on, inside the migration's one transaction).
CREATE TABLE jobs_new (
  id          INTEGER PRIMARY KEY,
  type        TEXT NOT NULL CHECK (type IN ('commit', 'refresh', 'reclassify', 'rollback')),
  state       TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
  params_json TEXT NOT NULL,
  progress    REAL NOT NULL DEFAULT 0,
  message     TEXT NOT NULL DEFAULT '',
  result_json TEXT,
  cancel_requested INTEGER NOT NULL DEFAULT 0,
  attempts    INTEGER NOT NULL DEFAULT 0,
  created_ms  INTEGER NOT NULL,
  started_ms  INTEGER,
  finished_ms INTEGER,
  lease_owner TEXT,            -- 003_job_leases.sql
  lease_expires_ms INTEGER
);
INSERT INTO jobs_new SELECT * FROM jobs;
CREATE TABLE job_tiles_new (
  job_id      INTEGER NOT NULL REFERENCES jobs_new(id),
  tile        TEXT NOT NULL,
  PRIMARY KEY (job_id, tile)
);
INSERT INTO job_tiles_new SELECT * FROM job_tiles;
DROP TABLE job_tiles;
DROP TABLE jobs;
-- Renaming rewrites job_tiles_new's reference to jobs_new into one to jobs.
ALTER TABLE jobs_new RENAME TO jobs;
ALTER TABLE job_tiles_new RENAME TO job_tiles;
CREATE INDEX jobs_state ON jobs (state, id);
