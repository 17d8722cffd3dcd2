// Unit test of the page's coverage layer helpers (web/src/coverage.js) on the server's JSON
// (GET /v1/coverage/tiles, docs/api.md): field names, the fill ramp's ends and middle, the
// tooltip's wording and ages. Oracles written out by hand.
import assert from 'node:assert/strict';
import { ageText, coverageRgb, coverageTooltip, normalizeCoverage } from '../../web/src/coverage.js';

const server = {
  tile: '0_0', bounds: [0, 0, 20, 20], prior_points: 128, observed_points: 64, fraction: 0.5,
  last_observed: '2026-12-04T20:00:00.000Z', sessions: 1, vehicles: 1,
};
const c = normalizeCoverage(server);
assert.deepEqual(c, {
  tile: '0_0', prior_points: 128, observed_points: 64, fraction: 0.5,
  last_observed: '2026-12-04T20:00:00.000Z', sessions: 1, vehicles: 1,
});
// Without a fraction it is derived; without prior points it is 0, not NaN.
assert.equal(normalizeCoverage({ ...server, fraction: undefined }).fraction, 0.5);
assert.equal(normalizeCoverage({ tile: '1_1', prior_points: 0, observed_points: 0 }).fraction, 0);
assert.equal(normalizeCoverage({ tile: '1_1' }).last_observed, null);

assert.deepEqual(coverageRgb(0), [224, 242, 241]);
assert.deepEqual(coverageRgb(1), [0, 105, 92]);
assert.deepEqual(coverageRgb(0.5), [112, 174, 167]);   // (224 + 0) / 2, (242 + 105) / 2 rounded, ...
assert.deepEqual(coverageRgb(-1), coverageRgb(0), 'clamped below');
assert.deepEqual(coverageRgb(7), coverageRgb(1), 'clamped above');

const now = Date.parse('2026-12-04T23:00:00.000Z');
assert.equal(ageText('2026-12-04T20:00:00.000Z', now), '3 h ago');
assert.equal(ageText('2026-12-04T22:59:30.000Z', now), 'just now');
assert.equal(ageText('2026-12-04T22:30:00.000Z', now), '30 min ago');
assert.equal(ageText('2026-11-24T23:00:00.000Z', now), '10 days ago');
assert.equal(ageText('not a time', now), 'unknown');
assert.equal(coverageTooltip(c, 30, now),
  'tile 0_0: 50% of 128 prior points observed in the last 30 days by 1 session, 1 vehicle; '
  + 'last observed 2026-12-04T20:00:00.000Z (3 h ago)');
assert.equal(coverageTooltip(normalizeCoverage({ tile: '2_0', prior_points: 10, sessions: 0, vehicles: 0 }), 7, now),
  'tile 2_0: 0% of 10 prior points observed in the last 7 days by 0 sessions, 0 vehicles; never observed');
console.log('all passed');
