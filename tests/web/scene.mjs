// A small constructed street scene of axis-aligned boxes, with analytic ground truth:
// the prior map is sampled from the box surfaces; a vehicle's keyframes are depth images
// ray-cast exactly against the changed scene (one box removed, one added, both in tile 1_0).
// Map frame z up, metres; camera x right, y down, z forward (docs/conventions.md).
import { deflateSync } from 'node:zlib';

export const TILE_SIZE = 50;
// The scene is served as a georeferenced map (UTM 32N, issue #24): every coordinate sent to
// the server is the scene's plus this origin, so the page must find the map far from (0, 0).
// Tile ids, PCD tiles and the page's drawing stay local (relative to it).
export const MAP_ORIGIN = [500000, 5400000, 100];
export const MAP_CRS = 'EPSG:32632';
export const toMap = (p) => p.map((v, a) => v + MAP_ORIGIN[a]);
export const CHANGED_TILE = '1_0';
const GROUND = { min: [0, -20, -1], max: [100, 50, 0] };          // top face is z = 0
const WALL = { min: [0, 34, 0], max: [100, 36, 14] };             // backdrop for the rays
const KEPT = [{ min: [12, 16, 0], max: [20, 22, 8] }];            // tile 0_0, unchanged
const REMOVED = { min: [60, 14, 0], max: [68, 20, 8] };           // tile 1_0, gone later
const ADDED = { min: [78, 22, 0], max: [86, 28, 9] };             // tile 1_0, new later

export const PRIOR_BOXES = [GROUND, WALL, ...KEPT, REMOVED];
export const CHANGED_BOXES = [GROUND, WALL, ...KEPT, ADDED];
export const ADDED_BOX = ADDED;
export const REMOVED_BOX = REMOVED;

// Points on every face of each box on a `step` grid (faces hidden inside the ground skipped).
export function sampleBoxes(boxes, step) {
  const pts = [];
  for (const b of boxes) {
    for (let axis = 0; axis < 3; axis++) {
      const [u, v] = [0, 1, 2].filter((a) => a !== axis);
      for (const side of [b.min[axis], b.max[axis]]) {
        if (axis === 2 && side <= 0 && b !== GROUND) continue;
        if (b === GROUND && !(axis === 2 && side === 0)) continue;   // ground: top face only
        for (let a = b.min[u]; a <= b.max[u] + 1e-9; a += step) {
          for (let c = b.min[v]; c <= b.max[v] + 1e-9; c += step) {
            const p = [0, 0, 0];
            p[axis] = side; p[u] = a; p[v] = c;
            pts.push(p);
          }
        }
      }
    }
  }
  return pts;
}

export function pcdAscii(points) {
  const head = `# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n`
    + `WIDTH ${points.length}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS ${points.length}\nDATA ascii\n`;
  return head + points.map((p) => p.map((v) => v.toFixed(3)).join(' ')).join('\n') + '\n';
}

// Slab test: distance along the ray to the first hit of the box, or Infinity.
function hitBox(o, d, b) {
  let t0 = 0, t1 = Infinity;
  for (let a = 0; a < 3; a++) {
    if (Math.abs(d[a]) < 1e-12) {
      if (o[a] < b.min[a] || o[a] > b.max[a]) return Infinity;
      continue;
    }
    let ta = (b.min[a] - o[a]) / d[a], tb = (b.max[a] - o[a]) / d[a];
    if (ta > tb) [ta, tb] = [tb, ta];
    t0 = Math.max(t0, ta); t1 = Math.min(t1, tb);
    if (t0 > t1) return Infinity;
  }
  return t0 > 0 ? t0 : Infinity;
}

export const CAMERA = { width: 320, height: 180, fx: 160, fy: 160, cx: 160, cy: 90 };
// Camera looking north (+y), level: columns of R_map_cam are the camera axes in the map.
const R_MAP_CAM = [[1, 0, 0], [0, 0, 1], [0, -1, 0]];
export const Q_MAP_CAM = [Math.SQRT1_2, -Math.SQRT1_2, 0, 0];   // qw qx qy qz of R_MAP_CAM

// Depth along the optical axis in millimetres (0 = nothing within maxDepth).
export function renderDepth(boxes, camPos, cam = CAMERA, maxDepth = 48) {
  const mm = new Uint16Array(cam.width * cam.height);
  for (let v = 0; v < cam.height; v++) {
    for (let u = 0; u < cam.width; u++) {
      const dc = [(u + 0.5 - cam.cx) / cam.fx, (v + 0.5 - cam.cy) / cam.fy, 1];
      const dm = [0, 1, 2].map((r) => R_MAP_CAM[r][0] * dc[0] + R_MAP_CAM[r][1] * dc[1] + R_MAP_CAM[r][2] * dc[2]);
      let t = Infinity;
      for (const b of boxes) t = Math.min(t, hitBox(camPos, dm, b));
      // dc has z = 1, so the ray parameter is the depth along the optical axis.
      if (t <= maxDepth) mm[v * cam.width + u] = Math.round(t * 1000);
    }
  }
  return mm;
}

const CRC_TABLE = Array.from({ length: 256 }, (_, n) => {
  let c = n;
  for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  return c >>> 0;
});
function crc32(buf) {
  let c = 0xffffffff;
  for (const b of buf) c = CRC_TABLE[(c ^ b) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}
function chunk(type, data) {
  const out = Buffer.alloc(12 + data.length);
  out.writeUInt32BE(data.length, 0);
  out.write(type, 4, 'latin1');
  data.copy(out, 8);
  out.writeUInt32BE(crc32(out.subarray(4, 8 + data.length)), 8 + data.length);
  return out;
}

// 16-bit greyscale PNG (big-endian samples), as depth_image.hpp reads them.
export function png16(values, width, height) {
  const raw = Buffer.alloc(height * (1 + width * 2));
  for (let y = 0; y < height; y++) {
    const row = y * (1 + width * 2);
    for (let x = 0; x < width; x++) raw.writeUInt16BE(values[y * width + x], row + 1 + x * 2);
  }
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(width, 0); ihdr.writeUInt32BE(height, 4);
  ihdr[8] = 16; ihdr[9] = 0; ihdr[10] = 0; ihdr[11] = 0; ihdr[12] = 0;
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
    chunk('IHDR', ihdr), chunk('IDAT', deflateSync(raw)), chunk('IEND', Buffer.alloc(0))]);
}

// The vehicle drives east along y = 6 at 2 m height, one keyframe every 4 m.
export function keyframePositions() {
  const out = [];
  for (let x = 4; x <= 96; x += 4) out.push([x, 6, 2]);
  return out;
}
