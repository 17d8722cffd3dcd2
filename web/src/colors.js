// Change-state colours shared by the top view, the list and the 3D legend.
export const STATE_COLORS = {
  none: [176, 190, 197],       // prior tile without changes
  candidate: [255, 179, 0],    // seen changed, not yet enough support
  confirmed: [229, 57, 53],    // enough sessions agree
  refreshed: [30, 136, 229],   // merged into a newer prior version
};

// Change points (top view and 3D view alike).
export const POINT_COLORS = { new: [67, 160, 71], removed: [216, 27, 96] };

// Confidence in [0,1] sets the fill's opacity so faint evidence looks faint.
export function stateFill(state, confidence) {
  const c = STATE_COLORS[state] ?? STATE_COLORS.candidate;
  const a = state === 'none' ? 0.35 : 0.25 + 0.7 * Math.max(0, Math.min(1, confidence));
  return `rgba(${c[0]},${c[1]},${c[2]},${a.toFixed(3)})`;
}

export function legendHtml() {
  return Object.entries(STATE_COLORS)
    .map(([k, c]) => `<span><i style="background:rgb(${c})"></i>${k}</span>`)
    .join('') + Object.entries(POINT_COLORS).map(([k, c]) => `<span><i style="background:rgb(${c})"></i>${k} point</span>`).join('')
    + '<span class="hint">opacity = confidence</span>';
}
