-- 008 for PostgreSQL (see ../008_tile_coverage.sql): per (tile, session) the prior points the
-- session observed.
CREATE TABLE tile_coverage (
  tile              TEXT NOT NULL,
  ix                BIGINT NOT NULL,
  iy                BIGINT NOT NULL,
  session_id        BIGINT NOT NULL,
  vehicle_id        TEXT NOT NULL,
  observed_ms       BIGINT NOT NULL,
  prior_row_version BIGINT NOT NULL,
  prior_points      BIGINT NOT NULL,
  observed_points   BIGINT NOT NULL,
  bits              BYTEA NOT NULL,
  PRIMARY KEY (tile, session_id)
);
CREATE INDEX tile_coverage_xy ON tile_coverage (ix, iy, observed_ms);
