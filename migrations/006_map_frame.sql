-- 006: the map's frame (issue #24): the CRS name its users' coordinates are in and the
-- origin, in those coordinates, that every stored point, pose and tile is relative to
-- (user = local + origin). One row at most (id = 1), written with the first prior version
-- that carries a frame and never changed afterwards. No row: a map from before frames, in
-- unnamed coordinates at origin 0.
CREATE TABLE map_frame (
  id INTEGER PRIMARY KEY CHECK (id = 1),
  crs TEXT NOT NULL,
  origin_x REAL NOT NULL,
  origin_y REAL NOT NULL,
  origin_z REAL NOT NULL
);
