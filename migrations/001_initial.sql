-- 001: the initial schema. Timestamps are milliseconds since the Unix epoch (UTC).
-- Blobs hold mapdelta's versioned, checksummed, compressed encodings (server/src/blob_codec.hpp).

CREATE TABLE tokens (
  id          TEXT PRIMARY KEY,              -- public id, shown by `token create`, used to revoke
  name        TEXT NOT NULL,
  role        TEXT NOT NULL CHECK (role IN ('vehicle', 'reader', 'admin')),
  hash        TEXT NOT NULL UNIQUE,          -- hex SHA-256 of the secret; the secret is never stored
  created_ms  INTEGER NOT NULL,
  revoked_ms  INTEGER
);

CREATE TABLE prior_versions (
  version     INTEGER PRIMARY KEY,
  created_ms  INTEGER NOT NULL,
  source      TEXT NOT NULL,                 -- 'import' or 'refresh'
  parent      INTEGER REFERENCES prior_versions(version),
  note        TEXT NOT NULL DEFAULT '',
  job_id      INTEGER
);

-- A tile's prior points at version V are the row with the greatest version <= V, so a refresh
-- only writes the tiles it changed and every old version stays readable.
CREATE TABLE prior_tiles (
  version     INTEGER NOT NULL REFERENCES prior_versions(version),
  tile        TEXT NOT NULL,
  ix          INTEGER NOT NULL,
  iy          INTEGER NOT NULL,
  point_count INTEGER NOT NULL,
  points      BLOB NOT NULL,
  PRIMARY KEY (tile, version)
);
CREATE INDEX prior_tiles_xy ON prior_tiles (ix, iy);

CREATE TABLE sessions (
  id           INTEGER PRIMARY KEY,
  vehicle_id   TEXT NOT NULL,
  camera_json  TEXT NOT NULL,
  depth_scale  REAL NOT NULL,
  state        TEXT NOT NULL CHECK (state IN ('open', 'committing', 'committed', 'failed')),
  created_ms   INTEGER NOT NULL,
  committed_ms INTEGER,
  job_id       INTEGER,
  registration_json TEXT
);

CREATE TABLE keyframes (
  session_id  INTEGER NOT NULL REFERENCES sessions(id),
  seq         INTEGER NOT NULL,
  t_ns        INTEGER NOT NULL,
  pose_json   TEXT NOT NULL,                 -- T_map_cam {"t":[..],"q":[qw,qx,qy,qz]}
  covariance  TEXT,                          -- JSON array of 36 or NULL
  depth_png   BLOB NOT NULL,
  content_sha TEXT NOT NULL,                 -- decides "same retry" (200) vs "conflict" (409)
  PRIMARY KEY (session_id, seq)
);

CREATE TABLE session_observed (
  session_id  INTEGER PRIMARY KEY REFERENCES sessions(id),
  observed    BLOB NOT NULL                  -- the session's observed octree (ObservedArea binary)
);

CREATE TABLE jobs (
  id          INTEGER PRIMARY KEY,
  type        TEXT NOT NULL CHECK (type IN ('commit', 'refresh', 'reclassify')),
  state       TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
  params_json TEXT NOT NULL,
  progress    REAL NOT NULL DEFAULT 0,
  message     TEXT NOT NULL DEFAULT '',
  result_json TEXT,
  cancel_requested INTEGER NOT NULL DEFAULT 0,
  attempts    INTEGER NOT NULL DEFAULT 0,
  created_ms  INTEGER NOT NULL,
  started_ms  INTEGER,
  finished_ms INTEGER
);
CREATE INDEX jobs_state ON jobs (state, id);

-- Tiles a job has already applied (each in its own transaction): a resumed job skips them.
CREATE TABLE job_tiles (
  job_id      INTEGER NOT NULL REFERENCES jobs(id),
  tile        TEXT NOT NULL,
  PRIMARY KEY (job_id, tile)
);

-- Per-tile aggregation across committed sessions. A tile's observed area is the merge of the
-- observed octrees (session_observed) of the sessions listed in tile_sessions: each session's
-- octree is stored once rather than copied into every tile it touches.
CREATE TABLE tile_state (
  tile        TEXT PRIMARY KEY,
  ix          INTEGER NOT NULL,
  iy          INTEGER NOT NULL,
  aggregate   BLOB NOT NULL,                 -- voxels with centroid and supporting session ids
  updated_ms  INTEGER NOT NULL
);
CREATE TABLE tile_sessions (
  tile        TEXT NOT NULL,
  session_id  INTEGER NOT NULL REFERENCES sessions(id),
  PRIMARY KEY (tile, session_id)
);

-- Latest classification of each tile.
CREATE TABLE tile_changes (
  tile          TEXT PRIMARY KEY,
  ix            INTEGER NOT NULL,
  iy            INTEGER NOT NULL,
  prior_version INTEGER NOT NULL,
  new_count     INTEGER NOT NULL,
  removed_count INTEGER NOT NULL,
  max_confidence REAL NOT NULL,
  changes       BLOB NOT NULL,
  params_json   TEXT NOT NULL,
  updated_ms    INTEGER NOT NULL
);
CREATE INDEX tile_changes_xy ON tile_changes (ix, iy);

-- What each refresh changed.
CREATE TABLE refresh_log (
  job_id        INTEGER NOT NULL,
  tile          TEXT NOT NULL,
  from_version  INTEGER NOT NULL,
  to_version    INTEGER NOT NULL,
  added         INTEGER NOT NULL,
  removed       INTEGER NOT NULL,
  PRIMARY KEY (job_id, tile)
);

CREATE TABLE settings (
  key   TEXT PRIMARY KEY,
  value TEXT NOT NULL
);
