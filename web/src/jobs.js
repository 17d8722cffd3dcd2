// Admin "refresh this tile": starts a refresh job and polls its status until it ends.
// Job states per the API: queued, running, then done / failed / cancelled.

const FINAL = new Set(['done', 'succeeded', 'completed', 'failed', 'cancelled', 'canceled']);

export async function runRefresh(api, tile, statusEl, { pollMs = 700, onDone } = {}) {
  statusEl.classList.remove('error');
  statusEl.textContent = `starting refresh of ${tile}…`;
  let job;
  try {
    job = await api.startRefresh(tile);
  } catch (e) {
    statusEl.classList.add('error');
    statusEl.textContent = e.message;
    return null;
  }
  const id = job.job_id ?? job.id;
  for (;;) {
    let j;
    try {
      j = await api.job(id);
    } catch (e) {
      statusEl.classList.add('error');
      statusEl.textContent = `job ${id}: ${e.message}`;
      return null;
    }
    const state = j.state ?? j.status ?? 'unknown';
    const progress = typeof j.progress === 'number' ? ` ${Math.round(j.progress * 100)}%` : '';
    statusEl.textContent = `job ${id}: ${state}${progress}${j.error ? ` — ${j.error.message ?? j.error}` : ''}`;
    statusEl.dataset.state = state;
    if (FINAL.has(state)) {
      if (state === 'failed') statusEl.classList.add('error');
      if (onDone) await onDone(j);
      return j;
    }
    await new Promise((r) => setTimeout(r, pollMs));
  }
}
