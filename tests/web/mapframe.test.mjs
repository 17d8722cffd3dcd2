// Unit test of the page's map frame (web/src/mapframe.js): a map in UTM, as GET /v1/map
// reports it, is drawn in local metres that float32 keeps to the millimetre, and the boxes it
// requests are back in UTM.
import assert from 'node:assert/strict';
import { LOCAL_FRAME, frameOf, initialBox, localXyz, toLocalBox, toMapBox } from '../../web/src/mapframe.js';

const utm = frameOf({
  crs: 'EPSG:32632', origin: [500000, 5400000, 100], prior_version: 1, tile_size_m: 20,
  extent: [499960, 5399980, 500080, 5400060],
});
assert.deepEqual(utm.origin, [500000, 5400000, 100]);
// The first view is the prior's extent, local: far from (0, 0) in UTM, near it here.
assert.deepEqual(initialBox(utm), [-40, -20, 80, 60]);
assert.equal(initialBox(frameOf({ crs: '', origin: [0, 0, 0], extent: null })), null);
// Requests go out in UTM and come back exactly.
const box = [-12.25, 3.5, 40.125, 18];
assert.deepEqual(toMapBox(utm, box), [499987.75, 5400003.5, 500040.125, 5400018]);
assert.deepEqual(toLocalBox(utm, toMapBox(utm, box)), box);
// Change points: local float32 keeps the millimetre that float32 of the UTM value loses.
const p = [500012.3456, 5400007.8912, 104.5];
const xyz = localXyz(utm, [{ p }]);
for (let a = 0; a < 3; a++) assert.ok(Math.abs(xyz[a] + utm.origin[a] - p[a]) < 1e-3, `axis ${a}`);
assert.ok(Math.abs(Math.fround(p[1]) - p[1]) > 0.05, 'float32 of a UTM northing is off by cm');
assert.equal(localXyz(utm, []), null);
// A map from before frames (or a malformed answer) is the local frame.
assert.deepEqual(frameOf({}).origin, LOCAL_FRAME.origin);
console.log('web.mapframe: ok');
