// The map's frame from GET /v1/map (CRS, origin, extent, in the map's own coordinates, e.g.
// UTM). The page draws in local metres (map coordinates - origin): canvas and three.js work in
// float32, which would round a UTM northing to 0.5 m, and the server's tile ids and PCD tiles
// are local too. Only requests (bbox, x/y) and change points cross between the two here, in
// float64.

export const LOCAL_FRAME = Object.freeze({ crs: '', origin: [0, 0, 0], extent: null });

export function frameOf(map) {
  const origin = Array.isArray(map?.origin) && map.origin.length === 3 ? map.origin.map(Number) : [0, 0, 0];
  const extent = Array.isArray(map?.extent) && map.extent.length === 4 ? map.extent.map(Number) : null;
  return { crs: map?.crs ?? '', origin, extent };
}

// [minx, miny, maxx, maxy] local -> map coordinates, and back.
export function toMapBox(frame, box) {
  const [ox, oy] = frame.origin;
  return [box[0] + ox, box[1] + oy, box[2] + ox, box[3] + oy];
}
export function toLocalBox(frame, box) {
  const [ox, oy] = frame.origin;
  return [box[0] - ox, box[1] - oy, box[2] - ox, box[3] - oy];
}

// Change points of a tile report ({p: [x, y, z]} in map coordinates) as local float32 xyz.
export function localXyz(frame, points) {
  if (!Array.isArray(points) || points.length === 0) return null;
  const xyz = new Float32Array(points.length * 3);
  points.forEach((c, i) => {
    for (let a = 0; a < 3; a++) xyz[i * 3 + a] = c.p[a] - frame.origin[a];
  });
  return xyz;
}

// The first view: the prior's extent, local; null when the map has no prior yet.
export function initialBox(frame) {
  return frame.extent ? toLocalBox(frame, frame.extent) : null;
}
