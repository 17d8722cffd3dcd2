// 2D top view of the tile grid: pan (drag), zoom (wheel), click to pick a tile. It draws
// whatever tiles the caller hands it and reports the visible x/y box so only tiles in view
// are fetched. World x points right, y up (map frame seen from above). Two layers: "changes"
// (tiles by change state, and the changed points themselves once tiles are big enough on
// screen) and "coverage" (tiles shaded by the fraction of their prior points observed lately).
import { POINT_COLORS, stateFill } from './colors.js';
import { coverageFill } from './coverage.js';

// Change points are drawn once a tile is at least this many pixels wide.
export const POINTS_MIN_TILE_PX = 24;

export class TopView {
  constructor(canvas, { onViewChange, onPick, tooltip = () => '' }) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d');
    this.onViewChange = onViewChange;
    this.onPick = onPick;
    this.center = [0, 0];
    this.scale = 2;                 // pixels per metre
    this.tileSize = 50;
    this.priorTiles = new Map();    // tile id -> points
    this.changed = new Map();       // tile id -> summary
    this.layer = 'changes';         // or 'coverage'
    this.coverage = new Map();      // tile id -> normalized coverage (coverage.js)
    this.points = new Map();        // tile id -> {new, removed}: Float32Array x,y pairs (local)
    this.tooltip = tooltip;         // tile id -> text of the canvas's title
    this.selected = null;
    this.bindEvents();
    new ResizeObserver(() => this.resize()).observe(canvas);
  }

  resize() {
    const r = this.canvas.getBoundingClientRect();
    const dpr = window.devicePixelRatio || 1;
    this.canvas.width = Math.max(1, Math.round(r.width * dpr));
    this.canvas.height = Math.max(1, Math.round(r.height * dpr));
    this.draw();
    this.viewChanged();
  }

  // Visible box [minx, miny, maxx, maxy] in map metres.
  bbox() {
    const dpr = window.devicePixelRatio || 1;
    const hw = this.canvas.width / dpr / 2 / this.scale, hh = this.canvas.height / dpr / 2 / this.scale;
    return [this.center[0] - hw, this.center[1] - hh, this.center[0] + hw, this.center[1] + hh];
  }

  fitTo(box) {
    const r = this.canvas.getBoundingClientRect();
    this.center = [(box[0] + box[2]) / 2, (box[1] + box[3]) / 2];
    const w = Math.max(box[2] - box[0], this.tileSize), h = Math.max(box[3] - box[1], this.tileSize);
    this.scale = Math.max(0.01, 0.9 * Math.min(r.width / w, r.height / h));
    this.draw();
    this.viewChanged();
  }

  viewChanged() {
    clearTimeout(this.timer);
    this.timer = setTimeout(() => this.onViewChange(this.bbox()), 120);
  }

  toScreen(x, y) {
    const dpr = window.devicePixelRatio || 1;
    return [(x - this.center[0]) * this.scale * dpr + this.canvas.width / 2,
      this.canvas.height / 2 - (y - this.center[1]) * this.scale * dpr];
  }

  toWorld(px, py) {
    const r = this.canvas.getBoundingClientRect();
    return [this.center[0] + (px - r.width / 2) / this.scale,
      this.center[1] - (py - r.height / 2) / this.scale];
  }

  // Tile width on screen, in CSS pixels.
  tilePixels() { return this.tileSize * this.scale; }

  tileAt(px, py) {
    const [x, y] = this.toWorld(px, py);
    return `${Math.floor(x / this.tileSize)}_${Math.floor(y / this.tileSize)}`;
  }

  bindEvents() {
    let drag = null;
    this.canvas.addEventListener('pointerdown', (e) => {
      drag = { x: e.clientX, y: e.clientY, c: [...this.center], moved: false };
      this.canvas.setPointerCapture(e.pointerId);
    });
    this.canvas.addEventListener('pointermove', (e) => {
      if (!drag) {
        const r = this.canvas.getBoundingClientRect();
        this.canvas.title = this.tooltip(this.tileAt(e.clientX - r.left, e.clientY - r.top)) ?? '';
        return;
      }
      const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
      if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
      this.center = [drag.c[0] - dx / this.scale, drag.c[1] + dy / this.scale];
      this.draw();
    });
    this.canvas.addEventListener('pointerup', (e) => {
      if (drag && !drag.moved) {
        const r = this.canvas.getBoundingClientRect();
        this.onPick(this.tileAt(e.clientX - r.left, e.clientY - r.top));
      } else if (drag) {
        this.viewChanged();
      }
      drag = null;
    });
    this.canvas.addEventListener('wheel', (e) => {
      e.preventDefault();
      const r = this.canvas.getBoundingClientRect();
      const px = e.clientX - r.left, py = e.clientY - r.top;
      const before = this.toWorld(px, py);
      this.scale = Math.min(200, Math.max(0.01, this.scale * Math.exp(-e.deltaY * 0.0015)));
      const after = this.toWorld(px, py);
      this.center = [this.center[0] + before[0] - after[0], this.center[1] + before[1] - after[1]];
      this.draw();
      this.viewChanged();
    }, { passive: false });
  }

  draw() {
    const { ctx, canvas } = this;
    const dpr = window.devicePixelRatio || 1;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = '#fafafa';
    ctx.fillRect(0, 0, canvas.width, canvas.height);
    const s = this.tileSize;
    const [minx, miny, maxx, maxy] = this.bbox();
    const px = s * this.scale * dpr;
    // Grid lines only when tiles are big enough on screen to read.
    if (px > 6) {
      ctx.strokeStyle = '#e0e0e0';
      ctx.lineWidth = 1;
      ctx.beginPath();
      for (let i = Math.floor(minx / s); i <= Math.ceil(maxx / s); i++) {
        const [x] = this.toScreen(i * s, 0);
        ctx.moveTo(x, 0); ctx.lineTo(x, canvas.height);
      }
      for (let j = Math.floor(miny / s); j <= Math.ceil(maxy / s); j++) {
        const [, y] = this.toScreen(0, j * s);
        ctx.moveTo(0, y); ctx.lineTo(canvas.width, y);
      }
      ctx.stroke();
    }
    const rect = (id) => {
      const [ix, iy] = id.split('_').map(Number);
      const [x0, y1] = this.toScreen(ix * s, (iy + 1) * s);
      return [x0, y1, px, px];
    };
    if (this.layer === 'coverage') {
      for (const [id, c] of this.coverage) {
        ctx.fillStyle = coverageFill(c.fraction);
        ctx.fillRect(...rect(id));
      }
    } else {
      for (const id of this.priorTiles.keys()) {
        if (this.changed.has(id)) continue;
        ctx.fillStyle = stateFill('none', 0);
        ctx.fillRect(...rect(id));
      }
      for (const [id, t] of this.changed) {
        ctx.fillStyle = stateFill(t.state, t.confidence);
        ctx.fillRect(...rect(id));
      }
      if (this.tilePixels() >= POINTS_MIN_TILE_PX) this.drawPoints(dpr);
    }
    if (px > 48) {
      ctx.fillStyle = '#37474f';
      ctx.font = `${11 * dpr}px system-ui`;
      const ids = this.layer === 'coverage' ? this.coverage.keys() : [...this.priorTiles.keys(), ...this.changed.keys()];
      for (const id of new Set(ids)) {
        const [x, y] = rect(id);
        ctx.fillText(id, x + 3 * dpr, y + 13 * dpr);
      }
    }
    if (this.selected) {
      ctx.strokeStyle = '#000';
      ctx.lineWidth = 2 * dpr;
      ctx.strokeRect(...rect(this.selected));
    }
  }

  // The changed points of the tiles in this.points: one square dot each (removed under new).
  drawPoints(dpr) {
    const { ctx, canvas } = this;
    const size = Math.max(2, Math.min(6, 0.5 * this.scale)) * dpr;   // about 0.5 m, 2..6 px
    for (const kind of ['removed', 'new']) {
      ctx.fillStyle = `rgb(${POINT_COLORS[kind]})`;
      for (const pts of this.points.values()) {
        const xy = pts[kind];
        if (!xy) continue;
        for (let i = 0; i < xy.length; i += 2) {
          const [x, y] = this.toScreen(xy[i], xy[i + 1]);
          if (x < -size || y < -size || x > canvas.width + size || y > canvas.height + size) continue;
          ctx.fillRect(x - size / 2, y - size / 2, size, size);
        }
      }
    }
  }
}
