// Page wiring: token, top view (changes or coverage layer) + list of changed tiles in view, tile
// detail (3D, evidence, versions), admin refresh. Everything comes from the same-origin REST API.
import './style.css';
import { Api, ApiError } from './api.js';
import { parseCloud } from './cloudparse.js';
import { legendHtml } from './colors.js';
import { coverageLegendHtml, coverageTooltip } from './coverage.js';
import { LOCAL_FRAME, frameOf, initialBox, localXyz, toMapBox } from './mapframe.js';
import { observedFootprint } from './octomap.js';
import { renderEvidence, summarizeReport } from './evidence.js';
import { runRefresh } from './jobs.js';
import { TileList } from './tilelist.js';
import { POINTS_MIN_TILE_PX, TopView } from './topview.js';
import { TileView3D } from './tileview3d.js';

const TOKEN_KEY = 'mapdelta.token';
const $ = (id) => document.getElementById(id);
const api = new Api(() => localStorage.getItem(TOKEN_KEY) || '');
const state = {
  priorVersion: null, tileSize: 50, summaries: new Map(), refreshed: new Set(), tile: null, version: null,
  frame: LOCAL_FRAME,   // the page works in local metres (mapframe.js)
};
let loadSeq = 0;

function status(text, isError = false) {
  $('status').textContent = text;
  $('status').classList.toggle('error', isError);
}

const top = new TopView($('topview'), { onViewChange: loadView, onPick: pickTile, tooltip: tileTooltip });
const list = new TileList($('tile-list'), $('tile-count'), pickTile);
const view = new TileView3D($('view3d'), $('view3d-info'));
// Change points are fetched for at most this many changed tiles in view (one request each).
const MAX_POINT_TILES = 60;
const pointCache = new Map();   // tile|min_confidence|updated_at -> {new, removed} local x,y

function coverageDays() {
  const d = Math.round(Number($('coverage-days').value));
  return Number.isFinite(d) && d >= 1 && d <= 3650 ? d : 30;
}

function showLegend() {
  $('legend-2d').innerHTML = top.layer === 'coverage' ? coverageLegendHtml(coverageDays()) : legendHtml();
}
showLegend();

function tileTooltip(id) {
  if (top.layer === 'coverage') {
    const c = top.coverage.get(id);
    return c ? coverageTooltip(c, coverageDays(), Date.now()) : `tile ${id}: no prior points`;
  }
  const t = top.changed.get(id);
  if (!t) return top.priorTiles.has(id) ? `tile ${id}: no changes` : '';
  if (t.state === 'refreshed') return `tile ${id}: refreshed`;
  return `tile ${id}: ${t.state}, confidence ${t.confidence.toFixed(2)}, ${t.new_points} new, ${t.removed_points} removed points`;
}

// x,y pairs (local) of a tile report's points.
function localXy(points) {
  const xyz = localXyz(state.frame, points);
  if (!xyz) return null;
  const xy = new Float32Array((xyz.length / 3) * 2);
  for (let i = 0, j = 0; i < xyz.length; i += 3, j += 2) { xy[j] = xyz[i]; xy[j + 1] = xyz[i + 1]; }
  return xy;
}

// The changed points of the changed tiles in view (when tiles are big enough to show them), for
// the top view; reports are cached until the tile's changes are updated.
async function loadPoints(tiles, minConf, seq) {
  const points = new Map();
  if (top.tilePixels() >= POINTS_MIN_TILE_PX && tiles.length <= MAX_POINT_TILES) {
    await Promise.all(tiles.map(async (t) => {
      const key = `${t.tile}|${minConf}|${t.updated_at}`;
      if (!pointCache.has(key)) {
        const report = await api.tileChanges(t.tile, minConf);
        pointCache.set(key, { new: localXy(report.new), removed: localXy(report.removed) });
      }
      points.set(t.tile, pointCache.get(key));
    }));
  }
  if (seq !== loadSeq) return;
  top.points = points;
  let n = 0;
  for (const p of points.values()) n += ((p.new?.length ?? 0) + (p.removed?.length ?? 0)) / 2;
  document.body.dataset.topPoints = String(n);   // for tests: change points in the top view
  top.draw();
}

function setPriorVersion(v) {
  if (v === null || v === undefined) return;
  state.priorVersion = v;
  $('prior-version').textContent = `prior v${v}`;
  const sel = $('version-select');
  if (sel.options.length !== v) {
    sel.replaceChildren(...Array.from({ length: v }, (_, i) => new Option(`v${i + 1}`, String(i + 1))));
  }
  if (!state.version) sel.value = String(v);
  $('before-after').disabled = v < 2;
}

// Only the tiles in the visible box (local) are requested, in the map's coordinates; prior
// tiles are skipped when zoomed out so far that they would be sub-pixel anyway.
async function loadView(localBox) {
  if (!localStorage.getItem(TOKEN_KEY)) return;
  const seq = ++loadSeq;
  try {
    const minConf = Number($('min-confidence').value) || 0;
    const bbox = toMapBox(state.frame, localBox);
    const changes = await api.changedTiles(bbox, minConf);
    const w = bbox[2] - bbox[0], h = bbox[3] - bbox[1];
    const prior = (w * h) / (state.tileSize ** 2) < 2500
      ? await api.priorTilesNear((bbox[0] + bbox[2]) / 2, (bbox[1] + bbox[3]) / 2, Math.min(Math.hypot(w, h) / 2, 1e4))
      : { tiles: [] };
    if (seq !== loadSeq) return;   // a newer view superseded this one
    setPriorVersion(changes.priorVersion ?? prior.priorVersion);
    if (changes.tileSize || prior.tileSize) state.tileSize = changes.tileSize ?? prior.tileSize;
    top.tileSize = state.tileSize;
    state.summaries = new Map(changes.tiles.map((t) => [t.tile, t]));
    // A tile whose prior row was written by a refresh job, and that has no newer changes,
    // shows as "refreshed".
    if (state.versionsOf !== state.priorVersion) {
      state.versions = await api.priorVersions();
      state.versionsOf = state.priorVersion;
    }
    if (seq !== loadSeq) return;
    state.refreshed = new Set(prior.tiles.filter((t) => state.versions.get(t.tileVersion)?.source === 'refresh')
      .map((t) => t.tile));
    const shown = new Map(state.summaries);
    for (const id of state.refreshed) {
      if (!shown.has(id)) shown.set(id, { tile: id, state: 'refreshed', confidence: 1 });
    }
    top.changed = shown;
    top.priorTiles = new Map(prior.tiles.map((t) => [t.tile, t.points]));
    let covered = '';
    if (top.layer === 'coverage') {
      const days = coverageDays();
      const cov = await api.coverageTiles(bbox, days);
      if (seq !== loadSeq) return;
      top.coverage = new Map(cov.tiles.map((c) => [c.tile, c]));
      const seen = cov.tiles.filter((c) => c.observed_points > 0).length;
      covered = `; ${seen} of ${cov.tiles.length} observed in the last ${days} days`;
      document.body.dataset.coverageTiles = String(cov.tiles.length);
    }
    top.draw();
    list.set(changes.tiles, changes.complete);
    status(`${changes.tiles.length} changed / ${prior.tiles.length} prior tiles in view${covered}`);
    if (top.layer === 'changes') await loadPoints(changes.tiles, minConf, seq);
  } catch (e) {
    if (seq === loadSeq) status(e.message, true);
  }
}

// First view: the prior's extent from GET /v1/map (wherever the map is: UTM or near 0).
// Without a prior, ask once over a wide box around the origin where changes are, then fit.
async function discover() {
  try {
    const map = await api.map();
    state.frame = frameOf(map);
    state.tileSize = map.tile_size_m ?? state.tileSize;
    top.tileSize = state.tileSize;
    setPriorVersion(map.prior_version);
    $('map-frame').textContent = state.frame.crs || (state.frame.origin.some((v) => v !== 0)
      ? `origin ${state.frame.origin.join(', ')}` : '');
    const box = initialBox(state.frame);
    if (box) { top.fitTo(box); return; }
    const wide = toMapBox(state.frame, [-1e4, -1e4, 1e4, 1e4]);   // the server's radius limit is 10 km
    const [changes, prior] = await Promise.all([
      api.changedTiles(wide, 0, 1),
      api.priorTilesNear(state.frame.origin[0], state.frame.origin[1], 1e4).catch(() => ({ tiles: [] }))]);
    state.tileSize = changes.tileSize ?? prior.tileSize ?? state.tileSize;
    top.tileSize = state.tileSize;
    setPriorVersion(changes.priorVersion ?? prior.priorVersion);
    const ids = [...changes.tiles.map((t) => t.tile), ...prior.tiles.map((t) => t.tile)];
    if (ids.length === 0) { status('no prior map and no changes yet'); top.fitTo([-100, -100, 100, 100]); return; }
    const s = state.tileSize, xy = ids.map((id) => id.split('_').map(Number));
    top.fitTo([Math.min(...xy.map((p) => p[0])) * s, Math.min(...xy.map((p) => p[1])) * s,
      (Math.max(...xy.map((p) => p[0])) + 1) * s, (Math.max(...xy.map((p) => p[1])) + 1) * s]);
  } catch (e) {
    status(e.message, true);
  }
}

async function loadCloud(promise) {
  try { return parseCloud(await promise); } catch (e) { if (e.status === 404) return null; throw e; }
}

async function pickTile(tile) {
  state.tile = tile;
  top.selected = tile; top.draw();
  list.select(tile);
  $('tile-title').textContent = tile;
  document.body.dataset.tileLoaded = '';
  const [ix, iy] = tile.split('_').map(Number);
  const s = state.tileSize;
  view.setTile([(ix + 0.5) * s, (iy + 0.5) * s], s);
  view.info(`loading ${tile}…`);
  const t0 = performance.now();
  try {
    const minConf = Number($('min-confidence').value) || 0;
    const summary = state.summaries.get(tile);
    // The JSON report carries every change point (position, confidence, sessions), so one
    // request gives both the evidence and the new/removed clouds.
    const report = summary ? await api.tileChanges(tile, minConf) : { tile };
    if (state.tile !== tile) return;
    const facts = summarizeReport(report, summary ?? { tile, state: state.refreshed.has(tile) ? 'refreshed' : 'none' });
    renderEvidence($('evidence'), facts);
    loadSessionDetails(tile, facts);
    view.setLayer('new', localXyz(state.frame, report.new));
    view.setLayer('removed', localXyz(state.frame, report.removed));
    await loadPrior(tile, state.version ?? state.priorVersion);
    if ($('show-observed').checked) await loadObserved(tile);
    view.frame();
    $('refresh-tile').disabled = !state.isAdmin;
    // Load time (requests, parsing, upload to the GPU, first frame) for users and tests.
    document.body.dataset.tileLoadMs = String(Math.round(performance.now() - t0));
    document.body.dataset.tileLoaded = tile;
  } catch (e) {
    view.info(`${tile}: ${e.message}`);
    status(e.message, true);
  }
}

// Vehicle and commit time of the sessions behind the evidence (at most 50 looked up).
async function loadSessionDetails(tile, facts) {
  const details = new Map();
  await Promise.all(facts.sessions.slice(0, 50).map(async (x) => {
    try { details.set(x.id, await api.session(x.id)); } catch { /* shown as unknown */ }
  }));
  if (state.tile === tile && details.size) renderEvidence($('evidence'), facts, details);
}

async function loadPrior(tile, version) {
  const prior = await loadCloud(api.priorTileCloud(tile, version));
  if (state.tile !== tile) return;
  view.setLayer('prior', prior);
  ['prior', 'new', 'removed'].forEach((k) => view.setVisible(k, $(`show-${k}`).checked));
  const c = view.counts(), shown = view.shown();
  const thinned = shown.prior < c.prior ? ` (showing ${shown.prior})` : '';
  view.info(`tile ${tile}   prior v${version ?? '?'}: ${c.prior ?? 0} pts${thinned}\n`
    + `new: ${c.new ?? 0} pts   removed: ${c.removed ?? 0} pts`);
  view.render();
}

// The observed octree is fetched only when asked for: it is the largest download of a tile.
async function loadObserved(tile) {
  try {
    const [ix, iy] = tile.split('_').map(Number);
    const buf = await api.observedTile(tile);
    if (state.tile !== tile) return;
    view.setFootprint(observedFootprint(buf, [ix * state.tileSize, iy * state.tileSize], state.tileSize));
  } catch (e) {
    if (e.status === 404) { view.setFootprint(null); return; }
    status(`observed area of ${tile}: ${e.message}`, true);
  }
}
$('show-observed').addEventListener('change', (e) => {
  if (!state.tile) return;
  if (e.target.checked) loadObserved(state.tile); else view.setFootprint(null);
});

for (const k of ['prior', 'new', 'removed']) {
  $(`show-${k}`).addEventListener('change', (e) => view.setVisible(k, e.target.checked));
}
$('version-select').addEventListener('change', async (e) => {
  state.version = Number(e.target.value);
  if (state.tile) await loadPrior(state.tile, state.version).catch((err) => status(err.message, true));
});
$('before-after').addEventListener('click', () => {
  const latest = state.priorVersion;
  const sel = $('version-select');
  sel.value = String(Number(sel.value) === latest ? latest - 1 : latest);
  sel.dispatchEvent(new Event('change'));
});
$('min-confidence').addEventListener('change', () => loadView(top.bbox()));
$('layer').addEventListener('change', (e) => {
  top.layer = e.target.value;
  showLegend();
  top.draw();
  loadView(top.bbox());
});
$('coverage-days').addEventListener('change', () => { showLegend(); loadView(top.bbox()); });
$('refresh-tile').addEventListener('click', async () => {
  if (!state.tile) return;
  const tile = state.tile;
  $('refresh-tile').disabled = true;
  await runRefresh(api, tile, $('job-status'), {
    onDone: async () => {
      document.body.dataset.tileLoaded = '';   // the tile is reloaded below
      state.version = null;
      await loadView(top.bbox());
      if (state.tile === tile) await pickTile(tile);
    },
  });
  $('refresh-tile').disabled = !state.isAdmin;
});

// The role badge appears only once the server accepted the token (api.role()).
async function start() {
  const token = localStorage.getItem(TOKEN_KEY);
  $('token-input').value = token ?? '';
  $('role').textContent = '';
  state.isAdmin = false;
  $('refresh-tile').disabled = true;
  if (!token) { status('enter a reader or admin token (see "where tokens come from")'); return; }
  let role;
  try {
    status('checking the token ...');
    role = await api.role();
  } catch (e) {
    if (e instanceof ApiError && e.status === 401) {
      status('token not accepted by the server (unknown or revoked): ask its admin for a reader token', true);
    } else {
      status(e.message, true);
    }
    return;
  }
  $('role').textContent = role;
  state.isAdmin = role === 'admin';
  if (role === 'vehicle') { status('a vehicle token can only upload: enter a reader or admin token', true); return; }
  await discover();
}

// For benchmarks and debugging from the console (bench/web/bench_web_tile.mjs).
window.mapdelta = { api, view, top, state, parseCloud, toMapBox };

$('token-form').addEventListener('submit', (e) => {
  e.preventDefault();
  localStorage.setItem(TOKEN_KEY, $('token-input').value.trim());
  start();
});
start();
