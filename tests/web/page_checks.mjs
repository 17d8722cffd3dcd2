// The browser half of the end-to-end test: open the page, enter the token, find the changed
// tile in the list, open its 3D view, check content and pixels, run an admin refresh and
// flip before/after. `expected` comes from the REST API (the same numbers the page must show).
import fs from 'node:fs';
import path from 'node:path';
import { canvasColourCounts, check, launchChromium } from './browser.mjs';
import { coverageRgb } from '../../web/src/coverage.js';

const CLEAR = [0x1b, 0x1f, 0x23];   // TileView3D clear colour
const COLOURS = { prior: [0x9e, 0x9e, 0x9e], new: [0x43, 0xa0, 0x47], removed: [0xd8, 0x1b, 0x60], clear: CLEAR };
const TOP_BACKGROUND = [0xfa, 0xfa, 0xfa];   // TopView's clear colour

// The top view's pixel (RGB) at a point of the map (local metres).
async function topPixelAt(page, x, y) {
  return page.evaluate(([x, y]) => {
    const { top } = window.mapdelta;
    const [px, py] = top.toScreen(x, y);
    return Array.from(top.ctx.getImageData(Math.round(px), Math.round(py), 1, 1).data.slice(0, 3));
  }, [x, y]);
}

// 1b. The top view draws the changed tile's points, and the coverage layer shades every prior
// tile by the fraction the REST API reports, with the numbers in the tile's tooltip.
async function checkTopViewLayers(page, expected, log) {
  await page.waitForFunction((n) => Number(document.body.dataset.topPoints) === n,
    expected.new_points + expected.removed_points, { timeout: 20000 });
  const px = await canvasColourCounts(page, '#topview', { new: COLOURS.new, removed: COLOURS.removed });
  log(`top view change points: ${JSON.stringify(px)}`);
  check(px.new > 20, `new points drawn in the top view (${px.new} px)`);
  check(px.removed > 20, `removed points drawn in the top view (${px.removed} px)`);

  await page.selectOption('#layer', 'coverage');
  await page.waitForFunction((n) => Number(document.body.dataset.coverageTiles) === n,
    expected.coverage.length, { timeout: 20000 });
  const tileSize = await page.evaluate(() => window.mapdelta.top.tileSize);
  const cv = await page.locator('#topview').boundingBox();
  for (const c of expected.coverage) {
    const [ix, iy] = c.tile.split('_').map(Number);
    const [x, y] = [(ix + 0.5) * tileSize, (iy + 0.5) * tileSize];
    // coverageFill is the ramp's colour at alpha 0.9 over the background.
    const want = coverageRgb(c.fraction).map((v, i) => 0.9 * v + 0.1 * TOP_BACKGROUND[i]);
    const got = await topPixelAt(page, x, y);
    log(`coverage ${c.tile}: fraction ${c.fraction.toFixed(3)}, pixel ${got} (expected ${want.map(Math.round)})`);
    check(got.every((v, i) => Math.abs(v - want[i]) <= 3), `tile ${c.tile} shaded by its fraction`);
    const [sx, sy] = await page.evaluate(([x, y]) => {
      const { top } = window.mapdelta;
      const dpr = window.devicePixelRatio || 1;
      return top.toScreen(x, y).map((v) => v / dpr);
    }, [x, y]);
    await page.mouse.move(cv.x + sx, cv.y + sy);
    const title = await page.getAttribute('#topview', 'title');
    check(title.includes(`${Math.round(100 * c.fraction)}% of ${c.prior_points} prior points`)
      && title.includes(c.last_observed ? `last observed ${c.last_observed}` : 'never observed'),
    `tooltip of ${c.tile} gives its coverage and freshness ("${title}")`);
  }
  await page.selectOption('#layer', 'changes');
}

// Enters a token in the page's form and waits until the page has judged it (a role badge or
// an error status).
async function enterToken(page, token) {
  await page.fill('#token-input', token);
  await page.click('#token-form button[type=submit]');
  await page.waitForFunction(() => document.getElementById('role').textContent !== ''
    || document.getElementById('status').classList.contains('error'), null, { timeout: 10000 });
}

export async function runPageChecks({ baseUrl, adminToken, readerToken, vehicleToken, expected, outDir, screenshots, log }) {
  const context = await launchChromium(outDir);
  try {
    const page = context.pages()[0] ?? await context.newPage();
    const errors = [];
    page.on('pageerror', (e) => errors.push(String(e)));
    // Every failed request is an error (the console line alone does not name the URL).
    // (401/403 are expected while probing tokens that are not admin's: see step 0.)
    let probingTokens = false;
    page.on('response', (r) => {
      const expectedAuth = probingTokens && (r.status() === 401 || r.status() === 403);
      if (r.status() >= 400 && !expectedAuth) errors.push(`HTTP ${r.status()} ${r.url()}`);
    });
    page.on('console', (m) => {
      if (m.type() === 'error' && !m.text().startsWith('Failed to load resource')) errors.push(m.text());
    });

    log('chromium started');
    await page.goto(baseUrl + '/', { waitUntil: 'load' });
    // 0. The page says where tokens come from, and shows a role only for an accepted token.
    check((await page.textContent('#token-help summary')) === 'where tokens come from', 'token help offered');
    check((await page.textContent('#token-help')).includes('mapdelta-server token create'),
      'token help names the command that creates tokens');
    probingTokens = true;
    await enterToken(page, 'not-a-token');
    check((await page.textContent('#role')) === '', 'no role shown for a token the server rejects');
    check((await page.textContent('#status')).includes('not accepted'), 'a rejected token is said so');
    await enterToken(page, vehicleToken);
    check((await page.textContent('#role')) === 'vehicle', 'vehicle token: role vehicle');
    check((await page.textContent('#status')).includes('can only upload'), 'a vehicle token is said to be upload-only');
    await enterToken(page, readerToken);
    check((await page.textContent('#role')) === 'reader', 'reader token: role reader');
    probingTokens = false;
    await page.fill('#token-input', adminToken);
    await page.click('#token-form button[type=submit]');
    check(await page.evaluate(() => localStorage.getItem('mapdelta.token')) === adminToken,
      'token stored in localStorage');

    // 1. The changed tile shows up in the list with the API's counts.
    const row = page.locator(`#tile-list tbody tr[data-tile="${expected.tile}"]`);
    await row.waitFor({ timeout: 20000 });
    const cells = await row.locator('td').allTextContents();
    log(`list row: ${cells.join(' | ')}`);
    check(cells[0] === expected.tile, `row tile id ${cells[0]} == ${expected.tile}`);
    check(Number(cells[3]) === expected.new_points, `row new ${cells[3]} == API ${expected.new_points}`);
    check(Number(cells[4]) === expected.removed_points, `row removed ${cells[4]} == API ${expected.removed_points}`);
    check((await page.textContent('#prior-version')) === `prior v${expected.prior_version}`, 'prior version badge');
    check((await page.textContent('#role')) === 'admin', 'admin role detected');
    await checkTopViewLayers(page, expected, log);

    // 2. Open its 3D view and evidence.
    await row.click();
    await page.waitForSelector(`body[data-tile-loaded="${expected.tile}"]`, { timeout: 30000 });
    const field = (f) => page.textContent(`#evidence [data-field="${f}"]`);
    check((await field('tile')) === expected.tile, 'evidence tile id');
    check(Number(await field('new')) === expected.new_points, 'evidence new count');
    check(Number(await field('removed')) === expected.removed_points, 'evidence removed count');
    const info = await page.textContent('#view3d-info');
    log(`3D overlay: ${info.replace(/\n/g, ' / ')}`);
    const px = await canvasColourCounts(page, '#view3d', COLOURS);
    log(`3D pixels: ${JSON.stringify(px)}`);
    check(px.clear < px.total, '3D canvas is not blank');
    check(px.prior > 50, `prior (grey) points drawn: ${px.prior} px`);
    check(px.new > 20, `new (green) points drawn: ${px.new} px`);
    check(px.removed > 20, `removed (magenta) points drawn: ${px.removed} px`);
    fs.mkdirSync(path.dirname(screenshots.main), { recursive: true });
    await page.screenshot({ path: screenshots.main });

    // Observed area: the tile's octree (.bt from the server) drawn as a cyan ground footprint
    // (alpha 110/255 over the dark background gives about rgb(15, 99, 111)).
    const btResponse = page.waitForResponse((r) => r.url().endsWith(`/v1/observed/tiles/${expected.tile}.bt`), { timeout: 10000 });
    await page.check('#show-observed');
    await btResponse;
    await page.waitForTimeout(300);
    const obs = await canvasColourCounts(page, '#view3d', { observed: [15, 99, 111] }, 30);
    log(`observed footprint pixels: ${obs.observed}`);
    check(obs.observed > 500, `observed footprint drawn (${obs.observed} px)`);
    await page.uncheck('#show-observed');

    // Only tiles in view are requested: pan the top view west, away from the tile; the list
    // empties and the request's bbox excludes it. Pan back: the tile is requested again.
    const tv = await page.locator('#topview').boundingBox();
    const drag = async (from, to) => {
      const req = page.waitForRequest((r) => r.url().includes('/v1/changes/tiles?'), { timeout: 10000 });
      await page.mouse.move(from, tv.y + tv.height / 2);
      await page.mouse.down();
      await page.mouse.move(to, tv.y + tv.height / 2, { steps: 8 });
      await page.mouse.up();
      // Requested in map (UTM) coordinates; compared in the scene's local ones.
      const box = new URL((await req).url()).searchParams.get('bbox').split(',').map(Number);
      return box.map((v, i) => v - expected.origin[i % 2]);
    };
    const away = await drag(tv.x + 10, tv.x + tv.width - 10);
    await page.waitForFunction(() => document.querySelector('#tile-list tbody').children.length === 0, null, { timeout: 10000 });
    log(`panned west: bbox requested ${away.join(',')}, list empty`);
    check(away[2] < 50, `the panned view's request excludes tile x >= 50 (bbox ${away.join(',')})`);
    const back = await drag(tv.x + tv.width - 10, tv.x + 10);
    await row.waitFor({ timeout: 10000 });
    log(`panned back: bbox requested ${back.join(',')}, ${expected.tile} listed again`);
    check(back[0] < 100 && back[2] > 50, `the view back over the tile requests it (bbox ${back.join(',')})`);

    // 3. Admin refresh of that tile: live job status to a final state, new prior version.
    await page.click('#refresh-tile');
    await page.waitForFunction(() => ['succeeded', 'failed', 'cancelled']
      .includes(document.querySelector('#job-status').dataset.state), null, { timeout: 60000 });
    const job = await page.textContent('#job-status');
    log(`job status: ${job}`);
    check(job.includes('succeeded'), `refresh job succeeded (${job})`);
    const v2 = expected.prior_version + 1;
    await page.waitForFunction((v) => document.querySelector('#prior-version').textContent === `prior v${v}`, v2, { timeout: 10000 });
    await page.waitForSelector(`body[data-tile-loaded="${expected.tile}"]`, { timeout: 30000 });

    // 4. Before/after: the refreshed tile's prior differs between the two versions.
    const priorCount = async () => {
      const text = await page.textContent('#view3d-info');
      const m = /prior v\d+: (\d+) pts/.exec(text);
      check(m, `3D overlay shows the prior count (got "${text}")`);
      return Number(m[1]);
    };
    const after = await priorCount();
    await page.click('#before-after');
    await page.waitForFunction((v) => /prior v(\d+):/.exec(document.querySelector('#view3d-info').textContent)?.[1] === String(v),
      expected.prior_version, { timeout: 10000 });
    const before = await priorCount();
    log(`prior points of ${expected.tile}: v${expected.prior_version} ${before}, v${v2} ${after}`);
    check(before === expected.prior_points_before, `before = API v${expected.prior_version} count ${expected.prior_points_before}`);
    check(after !== before, 'refresh changed the tile\'s prior points');
    if (screenshots.before) await page.screenshot({ path: screenshots.before });
    check(errors.length === 0, `no page errors (${errors.join('; ')})`);
    return { before, after, pixels: px };
  } finally {
    await context.close();
  }
}
