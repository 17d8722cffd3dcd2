// Unit test of the page's cloud and octree parsers against files written by PCL and OctoMap
// (tests/web/data/README.md gives how they were made and the reference figures).
import assert from 'node:assert/strict';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { parseCloud } from '../../web/src/cloudparse.js';
import { forEachBtLeaf, observedFootprint } from '../../web/src/octomap.js';

const data = path.join(path.dirname(fileURLToPath(import.meta.url)), 'data');
const read = (f) => fs.readFileSync(path.join(data, f));
let failures = 0;
function test(name, fn) {
  try { fn(); console.log(`ok   ${name}`); } catch (e) { failures++; console.log(`FAIL ${name}: ${e.message}`); }
}

for (const f of ['a.pcd', 'b.pcd', 'bc.pcd', 'a.ply', 'b.ply']) {
  test(`${f}: 40 points equal the written values`, () => {
    const xyz = parseCloud(read(f));
    assert.equal(xyz.length, 120);
    for (let i = 0; i < 40; i++) {
      const want = [0.5 * i, 3 - 1.25 * i, 0.1 * (i % 7)];
      for (let a = 0; a < 3; a++) assert.ok(Math.abs(xyz[i * 3 + a] - want[a]) < 1e-5, `point ${i} axis ${a}: ${xyz[i * 3 + a]} != ${want[a]}`);
    }
  });
}

test('truncated or garbled clouds throw named errors, never crash', () => {
  const b = read('b.pcd');
  assert.throws(() => parseCloud(b.subarray(0, b.length - 10)), /PCD binary: truncated/);
  assert.throws(() => parseCloud(Buffer.from('hello')), /no 'DATA' line/);
  const bc = Buffer.from(read('bc.pcd'));
  bc[bc.length - 5] ^= 0xff;
  assert.throws(() => parseCloud(bc), /LZF/);
  const ply = read('b.ply');
  assert.throws(() => parseCloud(ply.subarray(0, ply.length - 500)), /PLY binary: truncated/);
});

test('wall.bt: leaves match liboctomap (799 leaves, 993.280 m^3, 154 occupied, sum x 9363.2)', () => {
  let n = 0, vol = 0, occ = 0, sx = 0;
  const res = forEachBtLeaf(read('wall.bt'), (x, _y, _z, s, o) => { n++; vol += s ** 3; if (o) { occ++; sx += x; } });
  assert.equal(res, 0.8);
  assert.equal(n, 799);
  assert.ok(Math.abs(vol - 993.28) < 1e-6, `volume ${vol}`);
  assert.equal(occ, 154);
  assert.ok(Math.abs(sx - 9363.2) < 1e-3, `sum x ${sx}`);
});

test('wall.bt footprint: covers the wall line, not the far corner', () => {
  const { mask, cells } = observedFootprint(read('wall.bt'), [50, 0], 50, 50);   // 1 m cells
  assert.equal(mask[20 * cells + 10], 1, 'x 60, y 20 (on the wall) observed');
  assert.equal(mask[45 * cells + 48], 0, 'x 98, y 45 (never seen) unobserved');
});

test('truncated .bt throws', () => {
  const bt = read('wall.bt');
  assert.throws(() => forEachBtLeaf(bt.subarray(0, bt.length - 3), () => {}), /\.bt: truncated/);
  assert.throws(() => forEachBtLeaf(Buffer.from('# Octomap OcTree binary file\nid ColorOcTree\nres 0.1\ndata\n'), () => {}), /not OcTree/);
});

if (failures) { console.log(`${failures} failed`); process.exit(1); }
console.log('all passed');
