-- 007: change clusters and their lifecycle (issue #20). A cluster is a connected set of changed
-- voxels of one kind in a tile; it keeps its id across commits by voxel overlap
-- (server/src/change_lifecycle.cpp). Every state change is a row of cluster_transitions under
-- the next number of change_feed's one counter row (taken under that row's lock, so numbers
-- are handed out in commit order); change_clusters.seq is the number of its latest change, the
-- position GET /v1/changes/feed pages by.
CREATE TABLE change_clusters (
  id              INTEGER PRIMARY KEY,
  tile            TEXT NOT NULL,
  ix              INTEGER NOT NULL,
  iy              INTEGER NOT NULL,
  kind            TEXT NOT NULL CHECK (kind IN ('new', 'removed')),
  state           TEXT NOT NULL
                  CHECK (state IN ('candidate', 'confirmed', 'applied', 'expired', 'rejected')),
  point_count     INTEGER NOT NULL,
  min_x REAL NOT NULL, min_y REAL NOT NULL, min_z REAL NOT NULL,
  max_x REAL NOT NULL, max_y REAL NOT NULL, max_z REAL NOT NULL,
  centroid_x REAL NOT NULL, centroid_y REAL NOT NULL, centroid_z REAL NOT NULL,
  voxels          BLOB NOT NULL,          -- the cluster's voxel keys (service-encoded)
  evidence_json   TEXT NOT NULL,          -- supporting / contradicting sessions, vehicles, days
  prior_version   INTEGER NOT NULL,
  applied_version INTEGER,
  created_ms      INTEGER NOT NULL,
  updated_ms      INTEGER NOT NULL,
  seq             INTEGER NOT NULL
);
CREATE INDEX change_clusters_tile ON change_clusters (tile, state);
CREATE INDEX change_clusters_xy ON change_clusters (ix, iy);
CREATE INDEX change_clusters_seq ON change_clusters (seq);

CREATE TABLE cluster_transitions (
  seq         INTEGER PRIMARY KEY,
  cluster_id  INTEGER NOT NULL REFERENCES change_clusters(id),
  from_state  TEXT CHECK (from_state IN ('candidate', 'confirmed', 'applied', 'expired', 'rejected')),
  to_state    TEXT NOT NULL
              CHECK (to_state IN ('candidate', 'confirmed', 'applied', 'expired', 'rejected')),
  at_ms       INTEGER NOT NULL,
  cause       TEXT NOT NULL,
  job_id      INTEGER,
  session_id  INTEGER,
  actor       TEXT NOT NULL
);
CREATE INDEX cluster_transitions_cluster ON cluster_transitions (cluster_id, seq);

CREATE TABLE change_feed (
  id       INTEGER PRIMARY KEY CHECK (id = 1),
  last_seq INTEGER NOT NULL
);
INSERT INTO change_feed (id, last_seq) VALUES (1, 0);

-- A session's localization weight in [0, 1] (how much its evidence counts, set by its commit;
-- NULL = 1) and the report it came from (server/src/localization_quality.hpp).
ALTER TABLE sessions ADD COLUMN localization_weight REAL;
ALTER TABLE sessions ADD COLUMN localization_json TEXT;
