-- 005: per-tile work items of a commit job (issue #19), so that several workers classify
-- different tiles of one commit at the same time. An item is claimed by one worker
-- (lease_owner until lease_expires_ms; claims is the fencing token, bumped by every claim:
-- only the latest claim may complete it); its result is staged here (done_by set) and not
-- visible to readers until every item of the job is done, when all of them are copied into
-- tile_changes in one transaction (published = 1; the staged blob is dropped then).
CREATE TABLE tile_work (
  job_id           INTEGER NOT NULL REFERENCES jobs(id),
  tile             TEXT NOT NULL,
  ix               INTEGER NOT NULL,
  iy               INTEGER NOT NULL,
  prior_version    INTEGER NOT NULL,
  claims           INTEGER NOT NULL DEFAULT 0,
  lease_owner      TEXT,
  lease_expires_ms INTEGER,
  done_by          TEXT,
  new_count        INTEGER NOT NULL DEFAULT 0,
  removed_count    INTEGER NOT NULL DEFAULT 0,
  max_confidence   REAL NOT NULL DEFAULT 0,
  changes          BLOB,
  params_json      TEXT,
  updated_ms       INTEGER NOT NULL DEFAULT 0,
  published        INTEGER NOT NULL DEFAULT 0,
  PRIMARY KEY (job_id, tile)
);
