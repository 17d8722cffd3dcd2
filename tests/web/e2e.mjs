#!/usr/bin/env node
// End-to-end test of the web map against the real mapdelta-server:
//   1. start the server on a free loopback port with a fresh database, serving web/dist;
//   2. import a small box-scene prior and upload one vehicle session of the changed scene, in
//      UTM coordinates (scene.mjs MAP_ORIGIN: the page must find a map far from (0, 0));
//   3. check over REST that the changed tile is found where the scene changed (analytic truth);
//   4. drive headless Chromium over the page (list -> top view's change points and coverage layer
//      -> 3D view -> pixels -> refresh -> before/after).
// Usage: node e2e.mjs --server BIN --web-root DIR --out DIR [--screenshot FILE]
import fs from 'node:fs';
import path from 'node:path';
import { parseArgs } from 'node:util';
import { parseCloud } from '../../web/src/cloudparse.js';
import { check } from './browser.mjs';
import { runPageChecks } from './page_checks.mjs';
import * as S from './scene.mjs';
import { api, importPrior, uploadSession } from './seed.mjs';
import { startServer } from './server_proc.mjs';

const { values: args } = parseArgs({
  options: {
    server: { type: 'string' }, 'web-root': { type: 'string' }, out: { type: 'string' },
    screenshot: { type: 'string' }, help: { type: 'boolean' },
  },
});
if (args.help || !args.server || !args['web-root'] || !args.out) {
  console.log('usage: node e2e.mjs --server BIN --web-root DIR --out DIR [--screenshot FILE]');
  process.exit(args.help ? 0 : 2);
}
const t0 = Date.now();
const log = (m) => console.log(`[web.e2e ${((Date.now() - t0) / 1000).toFixed(1)}s] ${m}`);

// Fraction of points inside box b grown by margin m (metres).
function fractionIn(xyz, b, m) {
  let n = 0;
  for (let i = 0; i < xyz.length; i += 3) {
    if ([0, 1, 2].every((a) => xyz[i + a] >= b.min[a] - m && xyz[i + a] <= b.max[a] + m)) n++;
  }
  return xyz.length ? n / (xyz.length / 3) : 0;
}

async function main() {
  fs.rmSync(args.out, { recursive: true, force: true });
  fs.mkdirSync(args.out, { recursive: true });
  if (!fs.existsSync(path.join(args['web-root'], 'index.html'))) {
    throw new Error(`${args['web-root']}/index.html missing: build the page (tools/build-web.sh)`);
  }
  const server = await startServer({ bin: args.server, webRoot: args['web-root'], dir: args.out, log });
  try {
    const { base, tokens } = server;
    // The page itself is served by the server at `/`.
    const html = await (await fetch(base + '/')).text();
    check(html.includes('<canvas id="view3d"'), 'GET / serves the built web map');

    await importPrior(base, tokens.admin, log);
    await uploadSession(base, tokens.vehicle, log);

    // REST oracle: the changed tile is the one the scene changed, and its new/removed points
    // lie on the added/removed box (margin: 0.8 m voxels + th_ch).
    const reader = api(base, tokens.reader);
    const map = await reader.get('/v1/map');
    check(map.crs === S.MAP_CRS && map.origin.join() === S.MAP_ORIGIN.join(), `GET /v1/map names the frame (${JSON.stringify(map)})`);
    const bbox = [...S.toMap([-200, -200]), ...S.toMap([300, 300])].join(',');
    const list = await reader.get(`/v1/changes/tiles?bbox=${bbox}`);
    log(`changed tiles: ${JSON.stringify(list.tiles ?? list)}`);
    const row = (list.tiles ?? []).find((t) => t.tile === S.CHANGED_TILE);
    check(row, `tile ${S.CHANGED_TILE} is listed as changed`);
    // Tile 0_0 holds an unchanged box and the same ground and wall: nothing changed there.
    check((list.tiles ?? []).length === 1, `only ${S.CHANGED_TILE} changed (got ${(list.tiles ?? []).map((t) => t.tile)})`);
    const newPts = parseCloud(await reader.bytes(`/v1/changes/tiles/${S.CHANGED_TILE}?format=pcd&kind=new`));
    const rmPts = parseCloud(await reader.bytes(`/v1/changes/tiles/${S.CHANGED_TILE}?format=pcd&kind=removed`));
    const fNew = fractionIn(newPts, S.ADDED_BOX, 2.0), fRm = fractionIn(rmPts, S.REMOVED_BOX, 2.0);
    log(`new ${newPts.length / 3} pts (${(100 * fNew).toFixed(0)}% on the added box), `
      + `removed ${rmPts.length / 3} pts (${(100 * fRm).toFixed(0)}% on the removed box)`);
    check(newPts.length > 0 && fNew >= 0.7, 'new points lie on the added box');
    check(rmPts.length > 0 && fRm >= 0.7, 'removed points lie on the removed box');
    const newCount = row.new_points ?? row.new_count, rmCount = row.removed_points ?? row.removed_count;
    check(newCount === newPts.length / 3 && rmCount === rmPts.length / 3, 'list counts match the clouds');
    // Coverage: every prior tile of the scene is listed; the session observed some of the
    // changed tile's points (its cameras look at it), and the page must show these numbers.
    const coverage = (await reader.get(`/v1/coverage/tiles?bbox=${bbox}`)).tiles;
    log(`coverage: ${JSON.stringify(coverage.map((c) => [c.tile, c.fraction, c.sessions]))}`);
    const covered = coverage.find((c) => c.tile === S.CHANGED_TILE);
    check(covered && covered.observed_points > 0 && covered.fraction <= 1 && covered.sessions === 1
      && covered.vehicles === 1 && covered.last_observed, `the session covers ${S.CHANGED_TILE}`);
    const priorV1 = parseCloud(await reader.bytes(`/v1/prior/tiles/${S.CHANGED_TILE}?format=pcd&version=1`));

    const shotDir = path.join(args.out, 'screenshots');
    const result = await runPageChecks({
      baseUrl: base, adminToken: tokens.admin, readerToken: tokens.reader, vehicleToken: tokens.vehicle,
      outDir: args.out, log,
      expected: {
        tile: S.CHANGED_TILE, new_points: newCount, removed_points: rmCount,
        prior_version: list.prior_version, prior_points_before: priorV1.length / 3,
        origin: S.MAP_ORIGIN, coverage,
      },
      screenshots: { main: path.join(shotDir, 'web-map.png'), before: path.join(shotDir, 'web-map-before.png') },
    });
    // After the refresh, the tile's newest prior has the added box and lost the removed one.
    const priorV2 = parseCloud(await reader.bytes(`/v1/prior/tiles/${S.CHANGED_TILE}?format=pcd`));
    const onAdded = (c) => fractionIn(c, S.ADDED_BOX, 0.5) * (c.length / 3);
    log(`prior points on the added box: v1 ${onAdded(priorV1)}, v2 ${onAdded(priorV2)}`);
    check(onAdded(priorV2) > onAdded(priorV1), 'refreshed prior gained points on the added box');
    check(result.after === priorV2.length / 3, 'page shows the refreshed prior');
    if (args.screenshot) {
      fs.mkdirSync(path.dirname(args.screenshot), { recursive: true });
      fs.copyFileSync(path.join(shotDir, 'web-map.png'), args.screenshot);
      log(`screenshot copied to ${args.screenshot}`);
    }
  } finally {
    await server.stop();
  }
  log('PASS');
}

main().catch((e) => {
  console.error(`[web.e2e] FAIL: ${e.stack ?? e}`);
  process.exit(1);
});
