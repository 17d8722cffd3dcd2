// REST client for mapdelta-server (same origin; contract in docs/api.md and
// server/openapi.yaml). Every call carries the bearer token; errors become ApiError with the
// server's {"error":{"code","message"}} body so the page can say what went wrong.
import { normalizeCoverage } from './coverage.js';

export class ApiError extends Error {
  constructor(status, code, message, path) {
    super(`${path}: ${status} ${code}: ${message}`);
    this.status = status;
    this.code = code;
  }
}

export class Api {
  constructor(getToken, base = '') {
    this.getToken = getToken;
    this.base = base;
  }

  async request(path, { method = 'GET', body, accept = 'json' } = {}) {
    const headers = {};
    const token = this.getToken();
    if (token) headers.Authorization = `Bearer ${token}`;
    if (body !== undefined) headers['Content-Type'] = 'application/json';
    const res = await fetch(this.base + path, {
      method, headers, body: body === undefined ? undefined : JSON.stringify(body),
    });
    if (!res.ok) {
      let code = 'http_error', message = res.statusText;
      try {
        const j = await res.json();
        if (j && j.error) ({ code = code, message = message } = j.error);
      } catch { /* body was not JSON: keep the status text */ }
      throw new ApiError(res.status, code, message, path);
    }
    if (accept === 'bytes') return res.arrayBuffer();
    return res.json();
  }

  // Changed tiles intersecting bbox [minx,miny,maxx,maxy]; follows pages up to maxPages so a
  // view never asks for more than it can show.
  async changedTiles(bbox, minConfidence = 0, maxPages = 20) {
    const tiles = [];
    let priorVersion = null, tileSize = null, complete = true;
    for (let page = 1; page <= maxPages; page++) {
      const q = new URLSearchParams({
        bbox: bbox.map((v) => v.toFixed(2)).join(','),
        min_confidence: String(minConfidence), page: String(page), page_size: '200',
      });
      const j = await this.request(`/v1/changes/tiles?${q}`);
      priorVersion = j.prior_version ?? priorVersion;
      tileSize = j.tile_size_m ?? tileSize;
      const rows = j.tiles ?? j.items ?? [];
      tiles.push(...rows.map(normalizeTileSummary));
      const total = j.total ?? j.total_count;
      if (rows.length === 0 || (total !== undefined ? tiles.length >= total : rows.length < 200)) {
        complete = true;
        break;
      }
      complete = page < maxPages;
    }
    return { tiles, priorVersion, tileSize, complete };
  }

  // Coverage and freshness of the prior tiles in bbox over the last `days` days (coverage.js),
  // paged as changedTiles.
  async coverageTiles(bbox, days, maxPages = 20) {
    const tiles = [];
    let complete = true;
    for (let page = 1; page <= maxPages; page++) {
      const q = new URLSearchParams({
        bbox: bbox.map((v) => v.toFixed(2)).join(','), days: String(days), page: String(page), page_size: '500',
      });
      const j = await this.request(`/v1/coverage/tiles?${q}`);
      const rows = j.tiles ?? [];
      tiles.push(...rows.map(normalizeCoverage));
      if (rows.length === 0 || tiles.length >= (j.total ?? 0)) { complete = true; break; }
      complete = page < maxPages;
    }
    return { tiles, complete };
  }

  // The map's frame (CRS, origin), extent and prior version (web/src/mapframe.js).
  async map() {
    return this.request('/v1/map');
  }

  async priorTilesNear(x, y, radius) {
    const q = new URLSearchParams({ x: x.toFixed(2), y: y.toFixed(2), radius: radius.toFixed(1) });
    const j = await this.request(`/v1/prior/tiles?${q}`);
    const rows = Array.isArray(j) ? j : (j.tiles ?? []);
    return {
      priorVersion: j.prior_version ?? null,
      tileSize: j.tile_size_m ?? null,
      tiles: rows.map((r) => ({
        tile: r.tile ?? r.tile_id, points: r.points ?? 0, tileVersion: r.tile_version ?? null,
      })),
    };
  }

  tileChanges(tile, minConfidence = 0) {
    const q = new URLSearchParams({ format: 'json', min_confidence: String(minConfidence) });
    return this.request(`/v1/changes/tiles/${encodeURIComponent(tile)}?${q}`);
  }

  // version -> {source: 'import'|'refresh', ...}; empty if the server does not list versions.
  async priorVersions() {
    try {
      const j = await this.request('/v1/prior/versions');
      return new Map((j.versions ?? []).map((v) => [v.version, v]));
    } catch (e) {
      if (e instanceof ApiError && e.status === 404) return new Map();
      throw e;
    }
  }

  session(id) { return this.request(`/v1/sessions/${encodeURIComponent(id)}`); }

  tileChangeCloud(tile, kind, minConfidence = 0) {
    const q = new URLSearchParams({ format: 'pcd', kind, min_confidence: String(minConfidence) });
    return this.request(`/v1/changes/tiles/${encodeURIComponent(tile)}?${q}`, { accept: 'bytes' });
  }

  priorTileCloud(tile, version) {
    const q = new URLSearchParams({ format: 'pcd' });
    if (version) q.set('version', String(version));
    return this.request(`/v1/prior/tiles/${encodeURIComponent(tile)}?${q}`, { accept: 'bytes' });
  }

  observedTile(tile) {
    return this.request(`/v1/observed/tiles/${encodeURIComponent(tile)}.bt`, { accept: 'bytes' });
  }

  startRefresh(tile) {
    return this.request('/v1/admin/jobs', { method: 'POST', body: { type: 'refresh', tiles: [tile] } });
  }

  job(id) { return this.request(`/v1/admin/jobs/${encodeURIComponent(id)}`); }

  // The token's role, probed with what each role may do: only admins list jobs, readers (and
  // admins) read changes, vehicles neither. A token the server does not accept (unknown,
  // revoked) throws the ApiError with status 401, so the page never shows a role for it.
  async role() {
    const allowed = async (path) => {
      try {
        await this.request(path);
        return true;
      } catch (e) {
        if (e instanceof ApiError && e.status === 403) return false;
        throw e;
      }
    };
    if (await allowed('/v1/admin/jobs?page_size=1')) return 'admin';
    if (await allowed('/v1/changes/tiles?bbox=0,0,1,1&page_size=1')) return 'reader';
    return 'vehicle';
  }
}

// Refresh jobs apply changes with confidence >= 0.5 by default (server CreateJob), so a tile
// whose best change reaches that is "confirmed": a refresh would change it.
export const CONFIRM_CONFIDENCE = 0.5;

// One changed-tile row in the page's own field names, whatever spelling the server uses.
export function normalizeTileSummary(r) {
  const num = (...vals) => { for (const v of vals) if (typeof v === 'number') return v; return 0; };
  const confidence = num(r.max_confidence, r.confidence);
  return {
    tile: r.tile ?? r.tile_id,
    state: r.state ?? (confidence >= CONFIRM_CONFIDENCE ? 'confirmed' : 'candidate'),
    confidence,
    new_points: num(r.new_count, r.new_points, r.counts?.new),
    removed_points: num(r.removed_count, r.removed_points, r.counts?.removed),
    updated_at: r.updated_at ?? null,
    prior_version: r.prior_version ?? null,
  };
}
