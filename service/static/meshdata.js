// A mesh document turned into typed arrays once, so drawing and picking never walk JSON:
// coordinates, triangles, per-triangle and per-node values, unique edges, the outline, the worst
// triangles, and a uniform grid that finds the triangle under the pointer.

/** The metrics the viewer colours by, and how they read (the pictures use the same). */
export const METRICS = {
  quality: { label: "triangle quality (1 = equilateral)", on: "cell", ideal: 1, worst: 0, step: 0.1 },
  fitness: { label: "node fitness", on: "point", ideal: 1, worst: 0, step: 0.1 },
  // Region ids are categories: the viewer scales them from the first to the last id.
  region: { label: "region", on: "cell", ideal: 1, worst: 0, step: 1 },
};

/** Names by id of a document's `tags` or `regions` table (name -> id). */
export function namesById(table) {
  const out = new Map();
  for (const [name, id] of Object.entries(table || {})) out.set(id, name);
  return out;
}

/**
 * The colour scale [bad end, ideal] of a metric over some arrays of values: from the worst
 * value (with a little room, rounded outwards) to the ideal, as service.render.color_range.
 */
export function colorRange(metric, arrays) {
  let extreme = Infinity;
  for (const values of arrays) {
    for (let i = 0; i < values.length; i++) if (values[i] < extreme) extreme = values[i];
  }
  if (!Number.isFinite(extreme)) return [metric.worst, metric.ideal];
  const margin = metric.step / 4;
  let bad = Math.floor(Number(((extreme - margin) / metric.step).toFixed(6))) * metric.step;
  bad = Math.min(Math.max(bad, metric.worst), metric.ideal);
  if (Math.abs(bad - metric.ideal) < metric.step) bad = metric.ideal - metric.step;
  return [Number(bad.toFixed(6)), metric.ideal];
}

function floats(list) {
  return list ? Float32Array.from(list) : null;
}

/**
 * One mesh (the document itself or its `initial`). `nodeValues` is the per-node fitness that
 * belongs to it (point_data.fitness or point_data.fitness_initial).
 */
export class MeshData {
  constructor(part, nodeValues, worstCount = 10) {
    const pts = part.points;
    const tris = part.triangles;
    this.nPoints = pts.length;
    this.nTriangles = tris.length;
    this.xy = new Float64Array(2 * this.nPoints);
    let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    for (let i = 0; i < this.nPoints; i++) {
      const x = pts[i][0], y = pts[i][1];
      this.xy[2 * i] = x;
      this.xy[2 * i + 1] = y;
      if (x < x0) x0 = x; if (x > x1) x1 = x;
      if (y < y0) y0 = y; if (y > y1) y1 = y;
    }
    this.box = [x0, y0, x1, y1];
    this.tri = new Uint32Array(3 * this.nTriangles);
    for (let t = 0; t < this.nTriangles; t++) {
      const c = tris[t];
      this.tri[3 * t] = c[0]; this.tri[3 * t + 1] = c[1]; this.tri[3 * t + 2] = c[2];
    }
    const cells = part.cell_data || {};
    this.cell = {
      quality: floats(cells.quality),
      min_angle: floats(cells.min_angle),
      max_angle: floats(cells.max_angle),
      region: floats(cells.region),
    };
    // Tagged lines (boundary runs, interfaces, constraint lines): node pairs and tag ids.
    const lineData = part.line_data || {};
    this.lines = part.lines && lineData.tag ? Uint32Array.from(part.lines.flat()) : null;
    this.lineTag = this.lines ? Uint32Array.from(lineData.tag) : null;
    this.node = { fitness: floats(nodeValues) };
    this._edges();
    this.worst = this._worst(worstCount);
    this.meanEdge = this._meanEdge();
    this._grid = null;
  }

  /** Values of a metric, and whether they are per triangle ("cell") or per node. */
  values(name) {
    const metric = METRICS[name];
    return metric.on === "cell" ? this.cell[name] : this.node[name];
  }

  _edges() {
    const n = this.nPoints, m = this.nTriangles, tri = this.tri;
    // One number per edge (smaller index * n + larger): a typed sort dedupes them fast.
    const keys = new Float64Array(3 * m);
    for (let t = 0; t < m; t++) {
      for (let k = 0; k < 3; k++) {
        const a = tri[3 * t + k], b = tri[3 * t + ((k + 1) % 3)];
        keys[3 * t + k] = a < b ? a * n + b : b * n + a;
      }
    }
    keys.sort();
    const edges = [], outline = [];
    for (let i = 0; i < keys.length; ) {
      let j = i + 1;
      while (j < keys.length && keys[j] === keys[i]) j++;
      const a = Math.floor(keys[i] / n), b = keys[i] - a * n;
      edges.push(a, b);
      if (j - i === 1) outline.push(a, b);
      i = j;
    }
    this.edges = Uint32Array.from(edges);
    this.outline = Uint32Array.from(outline);
  }

  _worst(k) {
    const q = this.cell.quality;
    if (!q || !q.length || k <= 0) return new Uint32Array(0);
    k = Math.min(k, q.length);
    const sorted = Float32Array.from(q).sort();
    const limit = sorted[k - 1];
    const out = [];
    for (let t = 0; t < q.length && out.length < k; t++) if (q[t] <= limit) out.push(t);
    return Uint32Array.from(out.sort((a, b) => q[a] - q[b]));
  }

  _meanEdge() {
    let area = 0;
    const { xy, tri } = this;
    for (let t = 0; t < this.nTriangles; t++) {
      const a = 2 * tri[3 * t], b = 2 * tri[3 * t + 1], c = 2 * tri[3 * t + 2];
      area += Math.abs((xy[b] - xy[a]) * (xy[c + 1] - xy[a + 1]) - (xy[b + 1] - xy[a + 1]) * (xy[c] - xy[a]));
    }
    const mean = area / 2 / Math.max(1, this.nTriangles);
    return Math.sqrt((4 / Math.sqrt(3)) * mean);
  }

  /** Centroid of triangle t. */
  centroid(t) {
    const { xy, tri } = this;
    const a = 2 * tri[3 * t], b = 2 * tri[3 * t + 1], c = 2 * tri[3 * t + 2];
    return [(xy[a] + xy[b] + xy[c]) / 3, (xy[a + 1] + xy[b + 1] + xy[c + 1]) / 3];
  }

  /** The triangle containing (x, y), or -1. */
  pick(x, y) {
    const g = this._grid || (this._grid = this._buildGrid());
    const i = Math.floor((x - g.x0) / g.cell), j = Math.floor((y - g.y0) / g.cell);
    if (i < 0 || j < 0 || i >= g.nx || j >= g.ny) return -1;
    const c = j * g.nx + i;
    const { xy, tri } = this;
    for (let s = g.start[c]; s < g.start[c + 1]; s++) {
      const t = g.items[s];
      const a = 2 * tri[3 * t], b = 2 * tri[3 * t + 1], d = 2 * tri[3 * t + 2];
      const d1 = (x - xy[b]) * (xy[a + 1] - xy[b + 1]) - (xy[a] - xy[b]) * (y - xy[b + 1]);
      const d2 = (x - xy[d]) * (xy[b + 1] - xy[d + 1]) - (xy[b] - xy[d]) * (y - xy[d + 1]);
      const d3 = (x - xy[a]) * (xy[d + 1] - xy[a + 1]) - (xy[d] - xy[a]) * (y - xy[a + 1]);
      const neg = d1 < 0 || d2 < 0 || d3 < 0, pos = d1 > 0 || d2 > 0 || d3 > 0;
      if (!(neg && pos)) return t;
    }
    return -1;
  }

  /** The node nearest (x, y) among the corners of triangle t. */
  nearestCorner(t, x, y) {
    let best = -1, dist = Infinity;
    for (let k = 0; k < 3; k++) {
      const p = this.tri[3 * t + k];
      const d = (this.xy[2 * p] - x) ** 2 + (this.xy[2 * p + 1] - y) ** 2;
      if (d < dist) { dist = d; best = p; }
    }
    return best;
  }

  _buildGrid() {
    // A uniform grid of about two triangles per cell, stored as one list per cell (CSR).
    const [x0, y0, x1, y1] = this.box;
    const w = Math.max(x1 - x0, 1e-12), h = Math.max(y1 - y0, 1e-12);
    const cell = Math.sqrt((w * h) / Math.max(1, this.nTriangles / 2));
    const nx = Math.max(1, Math.ceil(w / cell)), ny = Math.max(1, Math.ceil(h / cell));
    const { xy, tri } = this, m = this.nTriangles;
    const span = new Int32Array(4 * m);
    const count = new Uint32Array(nx * ny + 1);
    for (let t = 0; t < m; t++) {
      let lx = Infinity, ly = Infinity, hx = -Infinity, hy = -Infinity;
      for (let k = 0; k < 3; k++) {
        const p = 2 * tri[3 * t + k];
        lx = Math.min(lx, xy[p]); hx = Math.max(hx, xy[p]);
        ly = Math.min(ly, xy[p + 1]); hy = Math.max(hy, xy[p + 1]);
      }
      const i0 = Math.max(0, Math.floor((lx - x0) / cell)), i1 = Math.min(nx - 1, Math.floor((hx - x0) / cell));
      const j0 = Math.max(0, Math.floor((ly - y0) / cell)), j1 = Math.min(ny - 1, Math.floor((hy - y0) / cell));
      span.set([i0, i1, j0, j1], 4 * t);
      for (let j = j0; j <= j1; j++) for (let i = i0; i <= i1; i++) count[j * nx + i + 1]++;
    }
    for (let c = 0; c < nx * ny; c++) count[c + 1] += count[c];
    const start = Uint32Array.from(count);
    const fill = Uint32Array.from(count);
    const items = new Uint32Array(count[nx * ny]);
    for (let t = 0; t < m; t++) {
      const [i0, i1, j0, j1] = span.subarray(4 * t, 4 * t + 4);
      for (let j = j0; j <= j1; j++) for (let i = i0; i <= i1; i++) items[fill[j * nx + i]++] = t;
    }
    return { x0, y0, cell, nx, ny, start, items };
  }
}

/** The meshes of a result document: `after` (the result) and `before` (its `initial`). */
export function meshesOf(doc) {
  const pointData = doc.point_data || {};
  const after = new MeshData(doc, pointData.fitness);
  const before = doc.initial ? new MeshData(doc.initial, pointData.fitness_initial) : null;
  return { after, before };
}
