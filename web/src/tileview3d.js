// three.js view of one tile: prior points grey, new points green, removed points magenta,
// with orbit controls. Points are shifted by the tile's centre so float32 keeps millimetres
// far from the map origin. preserveDrawingBuffer lets tests and screenshots read the canvas.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

export const LAYER_COLORS = { prior: 0x9e9e9e, new: 0x43a047, removed: 0xd81b60 };

export class TileView3D {
  constructor(canvas, infoEl) {
    this.canvas = canvas;
    this.infoEl = infoEl;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.renderer.setClearColor(0x1b1f23);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(50, 1, 0.1, 5000);
    this.camera.up.set(0, 0, 1);     // map frame is z up
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.addEventListener('change', () => this.render());
    this.layers = {};
    this.origin = new THREE.Vector3();
    this.scene.add(new THREE.GridHelper(50, 10, 0x455a64, 0x2e3a40).rotateX(Math.PI / 2));
    new ResizeObserver(() => this.resize()).observe(canvas);
  }

  resize() {
    const r = this.canvas.getBoundingClientRect();
    if (r.width < 1 || r.height < 1) return;
    this.renderer.setSize(r.width, r.height, false);
    this.camera.aspect = r.width / r.height;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  // Tile centre (map metres) and edge length; the grid and camera frame this square.
  setTile(center, size) {
    this.origin.set(center[0], center[1], 0);
    this.size = size;
    for (const name of Object.keys(this.layers)) this.setLayer(name, null);
    this.setFootprint(null);
    const grid = this.scene.children.find((c) => c.type === 'GridHelper');
    grid.scale.setScalar(size / 50);
  }

  // xyz: Float32Array in map coordinates, or null to drop the layer. Layers above `budget`
  // points are thinned by a fixed stride for display (counts() still reports the full size),
  // so orbiting stays interactive on weak GPUs and software rendering.
  setLayer(name, xyz, pointSize = 0.35, budget = 300000) {
    const old = this.layers[name];
    if (old) { this.scene.remove(old); old.geometry.dispose(); old.material.dispose(); }
    delete this.layers[name];
    if (!xyz) return;
    const total = xyz.length / 3;
    const stride = Math.max(1, Math.ceil(total / budget));
    const local = new Float32Array(Math.ceil(total / stride) * 3);
    for (let k = 0, o = 0; k < total; k += stride, o += 3) {
      local[o] = xyz[k * 3] - this.origin.x;
      local[o + 1] = xyz[k * 3 + 1] - this.origin.y;
      local[o + 2] = xyz[k * 3 + 2];
    }
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(local, 3));
    g.computeBoundingSphere();
    const m = new THREE.PointsMaterial({
      color: LAYER_COLORS[name] ?? 0xffffff, size: name === 'prior' ? pointSize : pointSize * 1.8,
      sizeAttenuation: true,
    });
    const pts = new THREE.Points(g, m);
    pts.name = name;
    pts.userData.total = total;
    this.layers[name] = pts;
    this.scene.add(pts);
  }

  // Observed area as a translucent cyan ground overlay (mask row 0 = tile's min y), or null.
  setFootprint(fp) {
    if (this.footprint) {
      this.scene.remove(this.footprint);
      this.footprint.geometry.dispose(); this.footprint.material.map.dispose(); this.footprint.material.dispose();
      this.footprint = null;
    }
    if (!fp) { this.render(); return; }
    const rgba = new Uint8Array(fp.cells * fp.cells * 4);
    for (let k = 0; k < fp.mask.length; k++) rgba.set(fp.mask[k] ? [0, 188, 212, 110] : [0, 0, 0, 0], k * 4);
    const tex = new THREE.DataTexture(rgba, fp.cells, fp.cells, THREE.RGBAFormat);
    tex.needsUpdate = true;
    const mat = new THREE.MeshBasicMaterial({ map: tex, transparent: true, depthWrite: false, side: THREE.DoubleSide });
    this.footprint = new THREE.Mesh(new THREE.PlaneGeometry(this.size, this.size), mat);
    this.footprint.position.z = -0.05;   // just under the ground points
    this.scene.add(this.footprint);
    this.render();
  }

  setVisible(name, visible) {
    if (this.layers[name]) this.layers[name].visible = visible;
    this.render();
  }

  shown() {
    const out = {};
    for (const [k, v] of Object.entries(this.layers)) out[k] = v.geometry.getAttribute('position').count;
    return out;
  }

  counts() {
    const out = {};
    for (const [k, v] of Object.entries(this.layers)) out[k] = v.userData.total;
    return out;
  }

  // Looks at everything loaded from the south-west, above, so buildings read as 3D.
  frame() {
    const box = new THREE.Box3();
    for (const l of Object.values(this.layers)) box.expandByObject(l);
    if (box.isEmpty()) box.setFromCenterAndSize(new THREE.Vector3(), new THREE.Vector3(this.size, this.size, 10));
    const c = box.getCenter(new THREE.Vector3());
    const r = Math.max(5, box.getSize(new THREE.Vector3()).length() / 2);
    this.controls.target.copy(c);
    this.camera.position.set(c.x - r * 1.1, c.y - r * 1.3, c.z + r * 1.1);
    this.camera.near = r / 200;
    this.camera.far = r * 20;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.renderNow();
  }

  info(text) { this.infoEl.textContent = text; }

  // Coalesces render requests into one frame per display refresh, so a burst of orbit events
  // never queues more draws than the renderer can do.
  render() {
    if (this.pending) return;
    this.pending = requestAnimationFrame(() => { this.pending = 0; this.renderNow(); });
  }

  renderNow() { this.renderer.render(this.scene, this.camera); }
}
