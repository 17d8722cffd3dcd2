-- 005 for PostgreSQL (see ../005_tile_work.sql): per-tile work items of a commit job, claimed
-- with FOR UPDATE SKIP LOCKED by several worker processes.
CREATE TABLE tile_work (
  job_id           BIGINT NOT NULL REFERENCES jobs(id),
  tile             TEXT NOT NULL,
  ix               BIGINT NOT NULL,
  iy               BIGINT NOT NULL,
  prior_version    BIGINT NOT NULL,
  claims           BIGINT NOT NULL DEFAULT 0,
  lease_owner      TEXT,
  lease_expires_ms BIGINT,
  done_by          TEXT,
  new_count        BIGINT NOT NULL DEFAULT 0,
  removed_count    BIGINT NOT NULL DEFAULT 0,
  max_confidence   DOUBLE PRECISION NOT NULL DEFAULT 0,
  changes          BYTEA,
  params_json      TEXT,
  updated_ms       BIGINT NOT NULL DEFAULT 0,
  published        BIGINT NOT NULL DEFAULT 0,
  PRIMARY KEY (job_id, tile)
);
-- Already compressed by the blob codec (as tile_changes.changes).
ALTER TABLE tile_work ALTER COLUMN changes SET STORAGE EXTERNAL;
