// Coverage and freshness of prior tiles (GET /v1/coverage/tiles, docs/api.md): the page's own
// field names, the fill of the top view's coverage layer and the tooltip text. Pure functions,
// tested in tests/web/coverage.test.mjs.

// Unobserved -> fully observed: pale to deep teal, so an unvisited tile still shows as prior.
const LOW = [224, 242, 241], HIGH = [0, 105, 92];

export function normalizeCoverage(r) {
  const num = (v) => (typeof v === 'number' && Number.isFinite(v) ? v : 0);
  const prior = num(r.prior_points), observed = num(r.observed_points);
  return {
    tile: r.tile,
    prior_points: prior,
    observed_points: observed,
    fraction: typeof r.fraction === 'number' ? r.fraction : (prior > 0 ? observed / prior : 0),
    last_observed: r.last_observed ?? null,
    sessions: num(r.sessions),
    vehicles: num(r.vehicles),
  };
}

// [r, g, b] of a fraction in [0, 1] (linear between LOW and HIGH).
export function coverageRgb(fraction) {
  const f = Math.max(0, Math.min(1, Number(fraction) || 0));
  return LOW.map((lo, i) => Math.round(lo + (HIGH[i] - lo) * f));
}

export function coverageFill(fraction) {
  const [r, g, b] = coverageRgb(fraction);
  return `rgba(${r},${g},${b},0.9)`;
}

export function coverageLegendHtml(days) {
  const stops = [0, 0.5, 1].map((f) => `<span><i style="background:rgb(${coverageRgb(f)})"></i>${f * 100}%</span>`);
  return stops.join('') + `<span class="hint">prior points observed in the last ${days} days</span>`;
}

// "3 h ago", "2 days ago": how old an ISO time is at nowMs.
export function ageText(iso, nowMs) {
  const t = Date.parse(iso);
  if (!Number.isFinite(t)) return 'unknown';
  const s = Math.max(0, (nowMs - t) / 1000);
  if (s < 90) return 'just now';
  if (s < 5400) return `${Math.round(s / 60)} min ago`;
  if (s < 129600) return `${Math.round(s / 3600)} h ago`;
  return `${Math.round(s / 86400)} days ago`;
}

// The tooltip of a tile in the coverage layer.
export function coverageTooltip(c, days, nowMs) {
  const pct = (100 * c.fraction).toFixed(c.fraction > 0 && c.fraction < 0.01 ? 2 : 0);
  const plural = (n, w) => `${n} ${w}${n === 1 ? '' : 's'}`;
  const last = c.last_observed ? `last observed ${c.last_observed} (${ageText(c.last_observed, nowMs)})` : 'never observed';
  return `tile ${c.tile}: ${pct}% of ${c.prior_points} prior points observed in the last ${days} days`
    + ` by ${plural(c.sessions, 'session')}, ${plural(c.vehicles, 'vehicle')}; ${last}`;
}
