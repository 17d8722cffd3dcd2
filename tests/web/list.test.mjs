// Unit test of the tile list's sorting and of the changed-tile normalisation the page applies
// to the server's JSON (docs/api.md, server/src/map_service_queries.cpp).
import assert from 'node:assert/strict';
import { CONFIRM_CONFIDENCE, normalizeTileSummary } from '../../web/src/api.js';
import { sortRows } from '../../web/src/tilelist.js';

const rows = [
  { tile: '1_0', confidence: 0.67, new_points: 199, removed_points: 667, updated_at: '2026-11-22T05:31:56.000Z' },
  { tile: '-2_3', confidence: 0.83, new_points: 5, removed_points: 0, updated_at: '2026-11-22T05:31:57.000Z' },
  { tile: '0_0', confidence: 0.67, new_points: 40, removed_points: 2, updated_at: '2026-11-21T23:00:00.000Z' },
  { tile: '10_0', confidence: 0.5, new_points: 0, removed_points: 9, updated_at: '2026-11-22T05:31:55.999Z' },
];
const ids = (r) => r.map((x) => x.tile).join(' ');
// Oracle: the orders written out by hand.
assert.equal(ids(sortRows(rows, 'confidence', -1)), '-2_3 0_0 1_0 10_0', 'confidence desc, ties by id');
assert.equal(ids(sortRows(rows, 'confidence', 1)), '10_0 0_0 1_0 -2_3', 'confidence asc, ties by id');
assert.equal(ids(sortRows(rows, 'updated_at', -1)), '-2_3 1_0 10_0 0_0', 'recency desc by time');
assert.equal(ids(sortRows(rows, 'removed_points', -1)), '1_0 10_0 0_0 -2_3', 'removed desc');
assert.equal(ids(rows), '1_0 -2_3 0_0 10_0', 'input not modified');

const server = {
  tile: '1_0', new_count: 199, removed_count: 667, max_confidence: 0.6667, prior_version: 1,
  bounds: [50, 0, 100, 50], updated_at: '2026-11-22T05:31:56.161Z', params: { th_ch_m: 3.2 },
};
assert.deepEqual(normalizeTileSummary(server), {
  tile: '1_0', state: 'confirmed', confidence: 0.6667, new_points: 199, removed_points: 667,
  updated_at: '2026-11-22T05:31:56.161Z', prior_version: 1,
});
assert.equal(normalizeTileSummary({ ...server, max_confidence: CONFIRM_CONFIDENCE - 0.01 }).state, 'candidate');
assert.equal(normalizeTileSummary({ ...server, state: 'refreshed' }).state, 'refreshed');
console.log('all passed');
