// Evidence panel of one tile: state, confidence, counts, and which sessions saw the tile and
// which support each change, with first/last seen times. Reads the tile's JSON change report.

function esc(s) {
  return String(s).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' }[c]));
}

function when(t) {
  if (t === undefined || t === null) return '—';
  // Accept ISO text, seconds or nanoseconds since the epoch.
  const d = typeof t === 'number' ? new Date(t > 1e15 ? t / 1e6 : t > 1e11 ? t : t * 1000) : new Date(t);
  return Number.isNaN(d.getTime()) ? esc(t) : d.toISOString().replace('T', ' ').replace('.000Z', 'Z');
}

// Pull the fields the panel shows out of the server's report, tolerating naming variants.
export function summarizeReport(report, summary) {
  const ev = report.evidence ?? {};
  const sessions = ev.sessions ?? report.sessions ?? [];
  const count = (k) => report[`${k}_points`] ?? report.counts?.[k]
    ?? (Array.isArray(report[k]) ? report[k].length : report[k]?.count ?? report[k]?.points?.length)
    ?? summary?.[`${k}_points`] ?? 0;
  return {
    tile: report.tile ?? summary?.tile,
    state: report.state ?? summary?.state ?? 'candidate',
    confidence: report.confidence ?? summary?.confidence ?? 0,
    priorVersion: report.prior_version ?? null,
    newCount: count('new'),
    removedCount: count('removed'),
    firstSeen: ev.first_seen ?? report.first_seen,
    lastSeen: ev.last_seen ?? report.last_seen,
    observedBy: ev.observed_by ?? ev.sessions_observed ?? sessions.length,
    supportNew: ev.support_new ?? ev.new_support ?? report.new?.support,
    supportRemoved: ev.support_removed ?? ev.removed_support ?? report.removed?.support,
    sessions,
  };
}

export function renderEvidence(el, s) {
  const sessionRows = s.sessions.map((x) => {
    const id = typeof x === 'object' ? (x.session_id ?? x.id) : x;
    const vehicle = typeof x === 'object' ? (x.vehicle_id ?? '') : '';
    const sup = typeof x === 'object'
      ? [x.supports_new ? `new ${x.supports_new}` : '', x.supports_removed ? `removed ${x.supports_removed}` : '']
        .filter(Boolean).join(', ') || (x.support ?? '—') : '—';
    return `<tr><td>${esc(id)}</td><td>${esc(vehicle)}</td><td>${esc(sup)}</td>
      <td>${when(x.first_seen ?? x.observed_at)}</td><td>${when(x.last_seen ?? x.observed_at)}</td></tr>`;
  }).join('');
  const support = (v) => (v === undefined ? '—' : esc(typeof v === 'object' ? JSON.stringify(v) : v));
  el.innerHTML = `
    <dl id="evidence-summary">
      <dt>tile</dt><dd data-field="tile">${esc(s.tile)}</dd>
      <dt>state</dt><dd data-field="state">${esc(s.state)}</dd>
      <dt>confidence</dt><dd data-field="confidence">${Number(s.confidence).toFixed(2)}</dd>
      <dt>new points</dt><dd data-field="new">${esc(s.newCount)}</dd>
      <dt>removed points</dt><dd data-field="removed">${esc(s.removedCount)}</dd>
      <dt>sessions observing</dt><dd data-field="observed">${esc(s.observedBy)}</dd>
      <dt>support (new / removed)</dt><dd>${support(s.supportNew)} / ${support(s.supportRemoved)}</dd>
      <dt>first / last seen</dt><dd>${when(s.firstSeen)} / ${when(s.lastSeen)}</dd>
      <dt>prior version</dt><dd>${esc(s.priorVersion ?? '—')}</dd>
    </dl>
    ${s.sessions.length ? `<table class="sessions"><thead><tr><th>session</th><th>vehicle</th>
      <th>supports</th><th>first seen</th><th>last seen</th></tr></thead><tbody>${sessionRows}</tbody></table>` : ''}`;
}
