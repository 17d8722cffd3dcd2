// Sortable table of the changed tiles in view. Clicking a header sorts by that column
// (again flips the order); clicking a row picks the tile.
import { STATE_COLORS } from './colors.js';

// Rows sorted by `key` (dir 1 ascending, -1 descending); ties by tile id so the order is
// stable across reloads. updated_at compares as time, not text.
export function sortRows(rows, key, dir) {
  const val = (r) => (key === 'updated_at' ? Date.parse(r.updated_at ?? '') || 0 : r[key]);
  return [...rows].sort((a, b) => {
    const va = val(a), vb = val(b);
    if (va < vb) return -dir;
    if (va > vb) return dir;
    return a.tile < b.tile ? -1 : a.tile > b.tile ? 1 : 0;
  });
}

export class TileList {
  constructor(table, countEl, onPick) {
    this.table = table;
    this.body = table.querySelector('tbody');
    this.countEl = countEl;
    this.onPick = onPick;
    this.rows = [];
    this.sort = { key: 'confidence', dir: -1 };
    this.selected = null;
    table.querySelectorAll('th').forEach((th) => th.addEventListener('click', () => {
      const key = th.dataset.key;
      this.sort = { key, dir: this.sort.key === key ? -this.sort.dir : (key === 'tile' ? 1 : -1) };
      this.render();
    }));
    this.body.addEventListener('click', (e) => {
      const tr = e.target.closest('tr[data-tile]');
      if (tr) this.onPick(tr.dataset.tile);
    });
  }

  set(rows, complete) {
    this.rows = rows;
    this.countEl.textContent = `${rows.length} tile${rows.length === 1 ? '' : 's'}${complete ? '' : ' (more exist; zoom in)'}`;
    this.render();
  }

  select(tile) { this.selected = tile; this.render(); }

  render() {
    const { key, dir } = this.sort;
    const rows = sortRows(this.rows, key, dir);
    this.table.querySelectorAll('th').forEach((th) => {
      th.classList.toggle('sorted-asc', th.dataset.key === key && dir > 0);
      th.classList.toggle('sorted-desc', th.dataset.key === key && dir < 0);
    });
    this.body.replaceChildren(...rows.map((r) => {
      const tr = document.createElement('tr');
      tr.dataset.tile = r.tile;
      if (r.tile === this.selected) tr.className = 'selected';
      const c = STATE_COLORS[r.state] ?? STATE_COLORS.candidate;
      const cells = [r.tile, r.state, r.confidence.toFixed(2), r.new_points, r.removed_points,
        r.updated_at ? new Date(r.updated_at).toLocaleString() : '—'];
      cells.forEach((v, i) => {
        const td = document.createElement('td');
        td.textContent = String(v);
        if (i === 1) td.style.borderLeft = `4px solid rgb(${c})`;
        tr.appendChild(td);
      });
      return tr;
    }));
  }
}
