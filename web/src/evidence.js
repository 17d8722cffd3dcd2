// Evidence panel of one tile: counts, confidence, and per session how many changed points it
// observed and supports, with when it was committed (first/last seen across sessions).
// Input: the server's JSON change report {tile, prior_version, updated_at, new: [{p,
// confidence, observed_by: [session ids], supported_by: [...]}], removed: [...]}.

function esc(s) {
  return String(s).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' }[c]));
}

function when(t) {
  if (t === undefined || t === null) return '—';
  const d = new Date(t);
  return Number.isNaN(d.getTime()) ? esc(t) : d.toISOString().replace('T', ' ').replace(/\.\d+Z$/, 'Z');
}

const ids = (v) => (Array.isArray(v) ? v : []);

// Per-session tallies over the tile's change points.
export function summarizeReport(report, summary) {
  const added = Array.isArray(report.new) ? report.new : [];
  const gone = Array.isArray(report.removed) ? report.removed : [];
  const sessions = new Map();
  const tally = (id) => {
    if (!sessions.has(id)) sessions.set(id, { id, observed: 0, supportsNew: 0, supportsRemoved: 0 });
    return sessions.get(id);
  };
  let confidence = 0;
  for (const [list, key] of [[added, 'supportsNew'], [gone, 'supportsRemoved']]) {
    for (const c of list) {
      confidence = Math.max(confidence, c.confidence ?? 0);
      for (const id of ids(c.observed_by)) tally(id).observed++;
      for (const id of ids(c.supported_by)) tally(id)[key]++;
    }
  }
  return {
    tile: report.tile ?? summary?.tile,
    state: summary?.state ?? 'none',
    confidence: summary?.confidence ?? confidence,
    priorVersion: report.prior_version ?? null,
    updatedAt: report.updated_at ?? summary?.updated_at,
    formula: report.confidence_formula,
    newCount: added.length,
    removedCount: gone.length,
    sessions: [...sessions.values()].sort((a, b) => a.id - b.id),
  };
}

// details: session id -> GET /v1/sessions/{id} body (vehicle_id, created_at, committed_at).
export function renderEvidence(el, s, details = new Map()) {
  const seen = s.sessions.map((x) => details.get(x.id)?.committed_at ?? details.get(x.id)?.created_at)
    .filter(Boolean).sort();
  const rows = s.sessions.map((x) => {
    const d = details.get(x.id) ?? {};
    return `<tr data-session="${esc(x.id)}"><td>${esc(x.id)}</td><td>${esc(d.vehicle_id ?? '—')}</td>
      <td>${x.observed}</td><td>${x.supportsNew}</td><td>${x.supportsRemoved}</td>
      <td>${when(d.committed_at ?? d.created_at)}</td></tr>`;
  }).join('');
  el.innerHTML = `
    <dl id="evidence-summary">
      <dt>tile</dt><dd data-field="tile">${esc(s.tile)}</dd>
      <dt>state</dt><dd data-field="state">${esc(s.state)}</dd>
      <dt>confidence (max)</dt><dd data-field="confidence" title="${esc(s.formula ?? '')}">${Number(s.confidence).toFixed(2)}</dd>
      <dt>new points</dt><dd data-field="new">${s.newCount}</dd>
      <dt>removed points</dt><dd data-field="removed">${s.removedCount}</dd>
      <dt>sessions with evidence</dt><dd data-field="sessions">${s.sessions.length}</dd>
      <dt>first / last seen</dt><dd>${when(seen[0])} / ${when(seen[seen.length - 1])}</dd>
      <dt>classified at</dt><dd>${when(s.updatedAt)} (prior v${esc(s.priorVersion ?? '?')})</dd>
    </dl>
    ${s.sessions.length ? `<table class="sessions"><thead><tr><th>session</th><th>vehicle</th>
      <th>observed pts</th><th>supports new</th><th>supports removed</th><th>committed</th></tr></thead>
      <tbody>${rows}</tbody></table>` : ''}`;
}
