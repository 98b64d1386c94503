// Drawing a mesh with canvas 2D, for browsers without WebGL2: triangles are sorted into colour
// bins once per colouring, and each frame fills one path per bin (64 fills, not 200,000),
// skipping triangles outside the view.

import { cssColorAt } from "./colormap.js";

const BINS = 64;
const PATH_BATCH = 500;

export class Canvas2DRenderer {
  constructor(canvas) {
    this.name = "canvas2d";
    this.ctx = canvas.getContext("2d", { alpha: false });
    this.mesh = null;
    this.order = null; // triangles sorted by bin
    this.binStart = null;
  }

  setMesh(mesh) {
    this.mesh = mesh;
    // Each triangle's bounding box, for culling.
    const { xy, tri, nTriangles } = mesh;
    this.boxes = new Float32Array(4 * nTriangles);
    for (let t = 0; t < nTriangles; t++) {
      const a = 2 * tri[3 * t], b = 2 * tri[3 * t + 1], c = 2 * tri[3 * t + 2];
      this.boxes[4 * t] = Math.min(xy[a], xy[b], xy[c]);
      this.boxes[4 * t + 1] = Math.min(xy[a + 1], xy[b + 1], xy[c + 1]);
      this.boxes[4 * t + 2] = Math.max(xy[a], xy[b], xy[c]);
      this.boxes[4 * t + 3] = Math.max(xy[a + 1], xy[b + 1], xy[c + 1]);
    }
  }

  setColors(values, perNode, lo, hi) {
    const { tri, nTriangles } = this.mesh;
    const bin = new Uint8Array(nTriangles);
    const count = new Uint32Array(BINS + 1);
    for (let t = 0; t < nTriangles; t++) {
      // Canvas 2D has no shading: a node value colours by the mean of the triangle's corners.
      const v = perNode ? (values[tri[3 * t]] + values[tri[3 * t + 1]] + values[tri[3 * t + 2]]) / 3 : values[t];
      const u = Math.min(1, Math.max(0, (v - lo) / (hi - lo)));
      bin[t] = Math.min(BINS - 1, Math.floor(u * BINS));
      count[bin[t] + 1]++;
    }
    for (let b = 0; b < BINS; b++) count[b + 1] += count[b];
    const fill = Uint32Array.from(count);
    this.order = new Uint32Array(nTriangles);
    for (let t = 0; t < nTriangles; t++) this.order[fill[bin[t]]++] = t;
    this.binStart = count;
  }

  draw(view, options) {
    const ctx = this.ctx;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = "#fbfcfd";
    ctx.fillRect(0, 0, view.width, view.height);
    if (!this.mesh || !this.order) return;
    const { xy, tri } = this.mesh;
    const s = view.scale, ox = view.width / 2 - view.cx * s, oy = view.height / 2 + view.cy * s;
    const X = (p) => ox + xy[2 * p] * s, Y = (p) => oy - xy[2 * p + 1] * s;
    // The view in data coordinates, for culling.
    const vx0 = -ox / s, vx1 = (view.width - ox) / s, vy0 = (oy - view.height) / s, vy1 = oy / s;
    const boxes = this.boxes;
    const visible = (t) =>
      boxes[4 * t + 2] >= vx0 && boxes[4 * t] <= vx1 && boxes[4 * t + 3] >= vy0 && boxes[4 * t + 1] <= vy1;
    let shown = 0;
    for (let t = 0; t < this.mesh.nTriangles; t++) if (visible(t)) shown++;
    // A hairline in the fill colour hides the seams anti-aliasing leaves between triangles;
    // stroking costs as much as filling, so only while few triangles are in view.
    const seams = shown < 30000;
    for (let b = 0; b < BINS; b++) {
      if (this.binStart[b] === this.binStart[b + 1]) continue;
      const colour = cssColorAt((b + 0.5) / BINS);
      ctx.fillStyle = colour;
      ctx.strokeStyle = colour;
      ctx.lineWidth = 0.6;
      let inPath = 0;
      const flush = () => {
        ctx.fill();
        if (seams) ctx.stroke();
        ctx.beginPath();
        inPath = 0;
      };
      ctx.beginPath();
      for (let i = this.binStart[b]; i < this.binStart[b + 1]; i++) {
        const t = this.order[i];
        if (!visible(t)) continue;
        const p = tri[3 * t], q = tri[3 * t + 1], r = tri[3 * t + 2];
        ctx.moveTo(X(p), Y(p));
        ctx.lineTo(X(q), Y(q));
        ctx.lineTo(X(r), Y(r));
        ctx.closePath();
        // Paths of many thousand contours fill super-linearly slowly: fill in batches.
        if (++inPath === PATH_BATCH) flush();
      }
      if (inPath) flush();
    }
    const W = view.width, H = view.height;
    const lines = (indices, style, width) => {
      ctx.strokeStyle = style;
      ctx.lineWidth = width;
      ctx.beginPath();
      let inPath = 0;
      for (let i = 0; i < indices.length; i += 2) {
        const x0 = X(indices[i]), y0 = Y(indices[i]), x1 = X(indices[i + 1]), y1 = Y(indices[i + 1]);
        if ((x0 < 0 && x1 < 0) || (x0 > W && x1 > W) || (y0 < 0 && y1 < 0) || (y0 > H && y1 > H)) continue;
        ctx.moveTo(x0, y0);
        ctx.lineTo(x1, y1);
        if (++inPath === PATH_BATCH) {
          ctx.stroke();
          ctx.beginPath();
          inPath = 0;
        }
      }
      ctx.stroke();
    };
    if (options.edgeAlpha > 0) lines(this.mesh.edges, `rgba(255, 255, 255, ${options.edgeAlpha})`, 1);
    lines(this.mesh.outline, "rgba(31, 41, 51, 0.9)", 1);
  }

  /** Wait until the canvas has drawn (for timing): reading a pixel back forces it. */
  finish() {
    this.ctx.getImageData(0, 0, 1, 1);
  }
}
