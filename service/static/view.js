// The mesh view: a WebGL2 (or canvas 2D) layer for the triangles and a 2D overlay for what is
// light to draw (the region being drawn, the worst triangles, the one under the pointer, an
// error's location). Drag pans, the wheel (or a pinch) zooms about the pointer.

import { WORST } from "./colormap.js";
import { Canvas2DRenderer } from "./canvas2d.js";
import { LAYERS, drawGeometry } from "./control.js";
import { GLRenderer } from "./gl.js";

const CLICK_SLOP = 4; // pixels a press may move and still be a click
/** Colours of tagged lines by tag id (matplotlib's Dark2, as the pictures' color=region). */
export const TAG_COLORS = ["#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02", "#a6761d", "#666666"];

function niceStep(span, target) {
  const raw = span / target;
  const p = 10 ** Math.floor(Math.log10(raw));
  const m = raw / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

export class MeshView extends EventTarget {
  /**
   * @param {{canvas: HTMLCanvasElement, overlay: HTMLCanvasElement, box: HTMLElement,
   *          renderer?: string}} parts  renderer: "webgl2" (default, falls back) or "canvas2d"
   */
  constructor({ canvas, overlay, box, renderer }) {
    super();
    this.canvas = canvas;
    this.overlay = overlay;
    this.box = box;
    this.octx = overlay.getContext("2d");
    this.renderer = null;
    if (renderer !== "canvas2d") {
      try {
        this.renderer = new GLRenderer(canvas);
      } catch (err) {
        console.info(`evomesh: drawing with canvas 2D (${err.message})`);
      }
    }
    this.renderer = this.renderer || new Canvas2DRenderer(canvas);
    this.cx = 0.5; this.cy = 0.5; this.scale = 300; // CSS pixels per unit
    this.mesh = null;
    this.region = null;   // parts of the region being previewed
    this.marker = null;   // {x, y, label}: where an error is
    this.hover = -1;      // the triangle under the pointer
    this.showEdges = true;
    this.showWorst = true;
    this.tool = null;     // the drawing tool, when active
    this.control = null;  // the job's {refinements, constraints} (control.js), drawn as layers
    this.layers = { refinements: true, constraints: true };
    this.controlDrawn = { refinements: 0, constraints: 0 }; // shapes drawn last frame
    this.lastFrameMs = 0;
    this._pending = false;
    this._pointers = new Map();
    this._resize();
    new ResizeObserver(() => this._resize()).observe(box);
    this._listen();
  }

  // -- coordinates ----------------------------------------------------------------------------

  get width() { return this.box.clientWidth; }
  get height() { return this.box.clientHeight; }

  toData(px, py) {
    return [this.cx + (px - this.width / 2) / this.scale, this.cy - (py - this.height / 2) / this.scale];
  }

  toScreen(x, y) {
    return [this.width / 2 + (x - this.cx) * this.scale, this.height / 2 - (y - this.cy) * this.scale];
  }

  /** Show the box [x0, y0, x1, y1] whole, clear of `pad` pixels (top, right, bottom, left). */
  fit(box, pad = [24, 24, 24, 24]) {
    const [x0, y0, x1, y1] = box;
    const [top, right, bottom, left] = pad;
    const w = Math.max(x1 - x0, 1e-9), h = Math.max(y1 - y0, 1e-9);
    const aw = Math.max(this.width - left - right, 10), ah = Math.max(this.height - top - bottom, 10);
    this.scale = Math.min(aw / w, ah / h);
    // The box's centre goes to the centre of the padded area.
    this.cx = (x0 + x1) / 2 - (left - right) / 2 / this.scale;
    this.cy = (y0 + y1) / 2 - (bottom - top) / 2 / this.scale;
    this.invalidate();
  }

  zoomAt(px, py, factor) {
    const [x, y] = this.toData(px, py);
    this.scale = Math.min(Math.max(this.scale * factor, 1e-9), 1e12);
    this.cx = x - (px - this.width / 2) / this.scale;
    this.cy = y + (py - this.height / 2) / this.scale;
    this.invalidate();
  }

  // -- content --------------------------------------------------------------------------------

  setMesh(mesh) {
    this.mesh = mesh;
    this.hover = -1;
    if (mesh) this.renderer.setMesh(mesh);
    this.invalidate();
  }

  setColors(values, perNode, lo, hi) {
    if (this.mesh) this.renderer.setColors(values, perNode, lo, hi);
    this.invalidate();
  }

  setRegion(parts) {
    this.region = parts;
    this.invalidate();
  }

  setMarker(marker) {
    this.marker = marker;
    this.invalidate();
  }

  // -- drawing --------------------------------------------------------------------------------

  _resize() {
    const dpr = window.devicePixelRatio || 1;
    for (const c of [this.canvas, this.overlay]) {
      c.width = Math.max(1, Math.round(this.width * dpr));
      c.height = Math.max(1, Math.round(this.height * dpr));
    }
    this.dpr = dpr;
    this.invalidate();
  }

  invalidate() {
    if (this._pending) return;
    this._pending = true;
    requestAnimationFrame(() => {
      this._pending = false;
      this.render();
    });
  }

  /** Draw now; `measure` waits for the GPU so lastFrameMs is the real cost. */
  render(measure = false) {
    const t0 = performance.now();
    const view = {
      width: this.canvas.width,
      height: this.canvas.height,
      scale: this.scale * this.dpr,
      cx: this.cx,
      cy: this.cy,
    };
    const edgePx = this.mesh ? this.mesh.meanEdge * this.scale : 0;
    // Edges fade in as triangles grow on screen: below ~4 pixels they would only be noise.
    const edgeAlpha = this.showEdges ? 0.6 * Math.min(1, Math.max(0, (edgePx - 4) / 8)) : 0;
    this.renderer.draw(view, { edgeAlpha });
    if (measure) this.renderer.finish();
    this.lastFrameMs = performance.now() - t0;
    this._drawOverlay();
    this.dispatchEvent(new CustomEvent("frame", { detail: { ms: this.lastFrameMs } }));
  }

  _path(ctx, ring) {
    ring.forEach(([x, y], i) => {
      const [sx, sy] = this.toScreen(x, y);
      if (i) ctx.lineTo(sx, sy);
      else ctx.moveTo(sx, sy);
    });
  }

  _triangle(ctx, t) {
    const { xy, tri } = this.mesh;
    ctx.beginPath();
    for (let k = 0; k < 3; k++) {
      const p = tri[3 * t + k];
      const [sx, sy] = this.toScreen(xy[2 * p], xy[2 * p + 1]);
      if (k) ctx.lineTo(sx, sy);
      else ctx.moveTo(sx, sy);
    }
    ctx.closePath();
  }

  /** Tagged lines, one colour per tag (TAG_COLORS, as the legend's). */
  _drawLines(ctx) {
    const { xy } = this.mesh, lines = this.mesh.lines, tag = this.mesh.lineTag;
    ctx.lineWidth = 2.5;
    for (let i = 0; i < tag.length; i++) {
      const a = lines[2 * i], b = lines[2 * i + 1];
      const [ax, ay] = this.toScreen(xy[2 * a], xy[2 * a + 1]);
      const [bx, by] = this.toScreen(xy[2 * b], xy[2 * b + 1]);
      ctx.beginPath();
      ctx.moveTo(ax, ay);
      ctx.lineTo(bx, by);
      ctx.strokeStyle = TAG_COLORS[(tag[i] - 1) % TAG_COLORS.length];
      ctx.stroke();
    }
  }

  /** The job's mesh control to draw over its mesh (null: none). */
  setControl(control) {
    this.control = control;
    this._drawOverlay();
  }

  /** Show or hide one layer of the mesh control. */
  setLayer(name, on) {
    this.layers[name] = on;
    this._drawOverlay();
  }

  _drawControl(ctx) {
    const toScreen = (x, y) => this.toScreen(x, y);
    this.controlDrawn = { refinements: 0, constraints: 0 };
    if (!this.control) return;
    ctx.save();
    ctx.lineWidth = 2;
    if (this.layers.refinements) {
      ctx.strokeStyle = LAYERS.refinements.color;
      ctx.setLineDash([6, 4]);
      for (const r of this.control.refinements) {
        this.controlDrawn.refinements += drawGeometry(ctx, r.geometry, toScreen, 7);
      }
    }
    ctx.setLineDash([]);
    if (this.layers.constraints) {
      ctx.strokeStyle = LAYERS.constraints.color;
      ctx.lineWidth = 3;
      for (const g of this.control.constraints) {
        this.controlDrawn.constraints += drawGeometry(ctx, g, toScreen, 5);
      }
    }
    ctx.restore();
  }

  _drawOverlay() {
    const ctx = this.octx;
    ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    ctx.clearRect(0, 0, this.width, this.height);
    if (this.tool) this._drawGrid(ctx);
    if (this.region && (!this.mesh || this.tool)) {
      ctx.beginPath();
      for (const part of this.region) for (const ring of part) { this._path(ctx, ring); ctx.closePath(); }
      ctx.fillStyle = "rgba(33, 145, 140, 0.10)";
      ctx.fill("evenodd");
      ctx.strokeStyle = "#1f2933";
      ctx.lineWidth = 1.5;
      ctx.stroke();
    }
    if (this.mesh && this.mesh.lines) this._drawLines(ctx);
    if (this.mesh) this._drawControl(ctx);
    if (this.mesh && this.showWorst) this._drawWorst(ctx);
    if (this.mesh && this.hover >= 0) {
      this._triangle(ctx, this.hover);
      ctx.strokeStyle = "#111";
      ctx.lineWidth = 2;
      ctx.stroke();
    }
    if (this.tool) this.tool.drawOverlay(ctx, this);
    if (this.marker) this._drawMarker(ctx);
  }

  _drawWorst(ctx) {
    const small = this.mesh.meanEdge * this.scale < 14;
    ctx.strokeStyle = WORST;
    ctx.lineWidth = 2;
    for (const t of this.mesh.worst) {
      this._triangle(ctx, t);
      ctx.stroke();
      if (small) {
        const [x, y] = this.mesh.centroid(t);
        const [sx, sy] = this.toScreen(x, y);
        ctx.beginPath();
        ctx.arc(sx, sy, 8, 0, 2 * Math.PI);
        ctx.stroke();
      }
    }
  }

  _drawMarker(ctx) {
    const [sx, sy] = this.toScreen(this.marker.x, this.marker.y);
    ctx.strokeStyle = WORST;
    ctx.lineWidth = 3;
    ctx.beginPath();
    ctx.moveTo(sx - 8, sy - 8); ctx.lineTo(sx + 8, sy + 8);
    ctx.moveTo(sx + 8, sy - 8); ctx.lineTo(sx - 8, sy + 8);
    ctx.stroke();
    ctx.beginPath();
    ctx.arc(sx, sy, 14, 0, 2 * Math.PI);
    ctx.lineWidth = 1.5;
    ctx.stroke();
    if (this.marker.label) {
      ctx.font = "12px system-ui, sans-serif";
      ctx.fillStyle = WORST;
      ctx.fillText(this.marker.label, sx + 18, sy - 10);
    }
  }

  _drawGrid(ctx) {
    const [x0, y1] = this.toData(0, 0), [x1, y0] = this.toData(this.width, this.height);
    const step = niceStep(Math.max(x1 - x0, y1 - y0), 10);
    const digits = Math.max(0, -Math.floor(Math.log10(step)));
    ctx.font = "10px system-ui, sans-serif";
    ctx.lineWidth = 1;
    for (let x = Math.ceil(x0 / step) * step; x <= x1; x += step) {
      const [sx] = this.toScreen(x, 0);
      ctx.strokeStyle = Math.abs(x) < step / 2 ? "#c5ccd3" : "#e9edf1";
      ctx.beginPath(); ctx.moveTo(sx, 0); ctx.lineTo(sx, this.height); ctx.stroke();
      ctx.fillStyle = "#9aa5b1";
      ctx.fillText(x.toFixed(digits), sx + 3, this.height - 4);
    }
    for (let y = Math.ceil(y0 / step) * step; y <= y1; y += step) {
      const [, sy] = this.toScreen(0, y);
      ctx.strokeStyle = Math.abs(y) < step / 2 ? "#c5ccd3" : "#e9edf1";
      ctx.beginPath(); ctx.moveTo(0, sy); ctx.lineTo(this.width, sy); ctx.stroke();
      ctx.fillStyle = "#9aa5b1";
      ctx.fillText(y.toFixed(digits), 3, sy - 3);
    }
  }

  // -- interaction ----------------------------------------------------------------------------

  _local(e) {
    const r = this.canvas.getBoundingClientRect();
    return [e.clientX - r.left, e.clientY - r.top];
  }

  _listen() {
    const c = this.canvas;
    c.addEventListener("pointerdown", (e) => {
      c.setPointerCapture(e.pointerId);
      const [px, py] = this._local(e);
      this._pointers.set(e.pointerId, { px, py, x0: px, y0: py, moved: false });
    });
    c.addEventListener("pointermove", (e) => this._move(e));
    const up = (e) => {
      const p = this._pointers.get(e.pointerId);
      this._pointers.delete(e.pointerId);
      this.box.classList.remove("panning");
      if (p && !p.moved && e.type === "pointerup" && e.button === 0) {
        const [x, y] = this.toData(p.px, p.py);
        if (this.tool) this.tool.click(x, y, p.px, p.py, this);
      }
    };
    c.addEventListener("pointerup", up);
    c.addEventListener("pointercancel", up);
    c.addEventListener("pointerleave", () => {
      if (!this._pointers.size) this._setHover(-1, null);
    });
    c.addEventListener("dblclick", (e) => {
      if (this.tool) this.tool.doubleClick(this);
      else {
        const [px, py] = this._local(e);
        this.zoomAt(px, py, 2);
      }
    });
    c.addEventListener(
      "wheel",
      (e) => {
        e.preventDefault();
        const [px, py] = this._local(e);
        const lines = e.deltaMode === 1 ? 16 : e.deltaMode === 2 ? 400 : 1;
        this.zoomAt(px, py, Math.exp(-e.deltaY * lines * 0.0015));
      },
      { passive: false },
    );
  }

  _move(e) {
    const [px, py] = this._local(e);
    const p = this._pointers.get(e.pointerId);
    if (!p) {
      this._hoverAt(px, py);
      return;
    }
    if (!p.moved && Math.hypot(px - p.x0, py - p.y0) < CLICK_SLOP) return;
    p.moved = true;
    if (this._pointers.size === 2) {
      // Pinch: zoom by the change of distance between the two pointers, about their middle.
      const [a, b] = [...this._pointers.values()];
      const before = Math.hypot(a.px - b.px, a.py - b.py);
      p.px = px; p.py = py;
      const after = Math.hypot(a.px - b.px, a.py - b.py);
      if (before > 0) this.zoomAt((a.px + b.px) / 2, (a.py + b.py) / 2, after / before);
      return;
    }
    this.box.classList.add("panning");
    this.cx -= (px - p.px) / this.scale;
    this.cy += (py - p.py) / this.scale;
    p.px = px; p.py = py;
    this.invalidate();
  }

  _hoverAt(px, py) {
    const [x, y] = this.toData(px, py);
    if (this.tool) {
      this.tool.move(x, y, px, py, this);
      this.dispatchEvent(new CustomEvent("hover", { detail: { x, y, t: -1 } }));
      return;
    }
    this._setHover(this.mesh ? this.mesh.pick(x, y) : -1, [x, y]);
  }

  _setHover(t, at) {
    if (t !== this.hover) {
      this.hover = t;
      this.invalidate();
    }
    this.dispatchEvent(new CustomEvent("hover", { detail: { x: at && at[0], y: at && at[1], t } }));
  }
}
