#!/usr/bin/env node
// Benchmark (not a test) of the web map on a paper-size prior (250 x 250 m, ~750k points, 25
// tiles of 50 m) served by the real mapdelta-server, in headless Debian Chromium:
//   ours     the page's way: one tile per 3D view (point budget 300k per layer);
//   baseline the whole map in one three.js cloud (what a viewer without tiling would load).
// Reports load time and frame time of each and the ratios. Note: --disable-gpu means
// SwiftShader (software GL); frame times on a real GPU are far smaller, ratios still hold.
// Usage: node bench/web/bench_web_tile.mjs --server BIN [--web-root DIR]
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { parseArgs } from 'node:util';
import { launchChromium } from '../../tests/web/browser.mjs';
import { pcdAscii } from '../../tests/web/scene.mjs';
import { startServer } from '../../tests/web/server_proc.mjs';

const { values: args } = parseArgs({ options: { server: { type: 'string' }, 'web-root': { type: 'string' }, help: { type: 'boolean' } } });
if (args.help || !args.server) {
  console.log('usage: node bench/web/bench_web_tile.mjs --server BIN [--web-root DIR]');
  process.exit(args.help ? 0 : 2);
}
const webRoot = args['web-root'] ?? path.join(path.dirname(new URL(import.meta.url).pathname), '../../web/dist');
const log = (m) => console.log(`[bench_web_tile] ${m}`);

// Ground every 0.35 m plus 36 buildings (LiDAR-like density), fixed layout: ~750k points.
function paperScene() {
  const pts = [];
  for (let x = 0; x < 250; x += 0.35) for (let y = 0; y < 250; y += 0.35) pts.push([x, y, 0]);
  for (let i = 0; i < 6; i++) {
    for (let j = 0; j < 6; j++) {
      const x0 = 10 + i * 40, y0 = 10 + j * 40, w = 18, h = 12 + ((i * 7 + j * 3) % 5) * 5;
      for (let z = 0; z <= h; z += 0.5) {
        for (let a = 0; a <= w; a += 0.5) pts.push([x0 + a, y0, z], [x0 + a, y0 + w, z], [x0, y0 + a, z], [x0 + w, y0 + a, z]);
      }
    }
  }
  return pts;
}

const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'mapdelta-bench-web-'));
const server = await startServer({ bin: args.server, webRoot, dir, log });
const context = await launchChromium(dir);
try {
  const pts = paperScene();
  log(`importing ${pts.length} points...`);
  const t0 = Date.now();
  const r = await fetch(`${server.base}/v1/admin/prior?format=pcd`, {
    method: 'POST', headers: { Authorization: `Bearer ${server.tokens.admin}`, 'Content-Type': 'application/octet-stream' },
    body: pcdAscii(pts),
  });
  log(`import: HTTP ${r.status} ${await r.text()} in ${Date.now() - t0} ms`);

  const page = context.pages()[0];
  await page.goto(server.base + '/');
  await page.fill('#token-input', server.tokens.reader);
  await page.click('#token-form button[type=submit]');
  await page.waitForFunction(() => /9|16|25 prior tiles/.test(document.querySelector('#status').textContent), null, { timeout: 30000 });
  log(`top view: ${await page.textContent('#status')}`);

  // Frame time: draw 10 frames, each forced to completion by reading one pixel back.
  const frameMs = () => page.evaluate(() => {
    const { view } = window.mapdelta, gl = view.renderer.getContext(), px = new Uint8Array(4);
    const t = performance.now();
    for (let i = 0; i < 10; i++) { view.renderNow(); gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px); }
    return (performance.now() - t) / 10;
  });

  // Ours: click one tile (a tile with a building), the page loads only it.
  await page.evaluate(() => { document.body.dataset.tileLoaded = ''; });
  const ours = [];
  for (let k = 0; k < 3; k++) {
    await page.evaluate(() => window.mapdelta.top.onPick('1_1'));
    await page.waitForSelector('body[data-tile-loaded="1_1"]', { timeout: 30000 });
    ours.push(Number(await page.evaluate(() => document.body.dataset.tileLoadMs)));
    await page.evaluate(() => { document.body.dataset.tileLoaded = ''; });
  }
  const oursPts = await page.evaluate(() => window.mapdelta.view.counts().prior);
  const oursFrame = await frameMs();

  // Baseline: every prior tile fetched, parsed and drawn as one cloud, no budget.
  const base = await page.evaluate(async () => {
    const { api, view, parseCloud } = window.mapdelta;
    const t = performance.now();
    const list = await api.priorTilesNear(125, 125, 200);
    const clouds = await Promise.all(list.tiles.map(async (x) => parseCloud(await api.priorTileCloud(x.tile))));
    const all = new Float32Array(clouds.reduce((n, c) => n + c.length, 0));
    let o = 0;
    for (const c of clouds) { all.set(c, o); o += c.length; }
    view.setTile([125, 125], 250);
    view.setLayer('new', null); view.setLayer('removed', null);
    view.setLayer('prior', all, 0.35, Infinity);
    view.frame();
    return { ms: performance.now() - t, points: all.length / 3, tiles: list.tiles.length };
  });
  const baseFrame = await frameMs();
  const med = (a) => [...a].sort((x, y) => x - y)[Math.floor(a.length / 2)];
  console.log('\n| | points drawn | load [ms] | frame [ms] |\n|---|---|---|---|');
  console.log(`| ours: one tile (1_1) | ${oursPts} | ${med(ours)} (median of 3) | ${oursFrame.toFixed(1)} |`);
  console.log(`| baseline: whole map (${base.tiles} tiles) | ${base.points} | ${base.ms.toFixed(0)} | ${baseFrame.toFixed(1)} |`);
  console.log(`| ratio baseline/ours | | ${(base.ms / med(ours)).toFixed(1)}x | ${(baseFrame / oursFrame).toFixed(1)}x |`);
} finally {
  await context.close();
  await server.stop();
  fs.rmSync(dir, { recursive: true, force: true });
}
