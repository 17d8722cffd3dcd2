-- 006 for PostgreSQL (see ../006_map_frame.sql): the map's frame, one row at most.
CREATE TABLE map_frame (
  id BIGINT PRIMARY KEY CHECK (id = 1),
  crs TEXT NOT NULL,
  origin_x DOUBLE PRECISION NOT NULL,
  origin_y DOUBLE PRECISION NOT NULL,
  origin_z DOUBLE PRECISION NOT NULL
);
