-- 008: coverage and freshness (issue #20 item 4). One row per (tile, session) the session's
-- commit touched: bits = which of the tile's prior points it observed (service-encoded bitset,
-- bit i = the i-th point of the prior tile row written by prior_row_version; 0 = no row). vehicle_id and observed_ms (the
-- session's created time) are copied from the session so a window of days needs no join; no
-- foreign key, as the rows are facts about what was observed (server/src/coverage.cpp).
CREATE TABLE tile_coverage (
  tile              TEXT NOT NULL,
  ix                INTEGER NOT NULL,
  iy                INTEGER NOT NULL,
  session_id        INTEGER NOT NULL,
  vehicle_id        TEXT NOT NULL,
  observed_ms       INTEGER NOT NULL,
  prior_row_version INTEGER NOT NULL,
  prior_points      INTEGER NOT NULL,
  observed_points   INTEGER NOT NULL,
  bits              BLOB NOT NULL,
  PRIMARY KEY (tile, session_id)
);
CREATE INDEX tile_coverage_xy ON tile_coverage (ix, iy, observed_ms);
