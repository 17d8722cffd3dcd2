// 2D top view of the tile grid: pan (drag), zoom (wheel), click to pick a tile. It draws
// whatever tiles the caller hands it and reports the visible x/y box so only tiles in view
// are fetched. World x points right, y up (map frame seen from above).
import { stateFill } from './colors.js';

export class TopView {
  constructor(canvas, { onViewChange, onPick }) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d');
    this.onViewChange = onViewChange;
    this.onPick = onPick;
    this.center = [0, 0];
    this.scale = 2;                 // pixels per metre
    this.tileSize = 50;
    this.priorTiles = new Map();    // tile id -> points
    this.changed = new Map();       // tile id -> summary
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
      if (!drag) return;
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
    for (const id of this.priorTiles.keys()) {
      if (this.changed.has(id)) continue;
      ctx.fillStyle = stateFill('none', 0);
      ctx.fillRect(...rect(id));
    }
    for (const [id, t] of this.changed) {
      ctx.fillStyle = stateFill(t.state, t.confidence);
      ctx.fillRect(...rect(id));
    }
    if (px > 48) {
      ctx.fillStyle = '#37474f';
      ctx.font = `${11 * dpr}px system-ui`;
      for (const id of new Set([...this.priorTiles.keys(), ...this.changed.keys()])) {
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
}
