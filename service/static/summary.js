// The summary table of a result (each stage's figures, as the API reports them), its timings
// and parameters, and the download links of every result format.

import { apiKey, api, resultUrl } from "./api.js";

const STAGES = [
  ["initial", "meshed"],
  ["swapped", "swapped"],
  ["smoothed", "smoothed"],
];

/** Rows: [label, path into a stage's summary, format, which direction is better]. */
const ROWS = [
  ["Mesh"],
  ["triangles", "count", "int"],
  ["points", "points", "int"],
  ["Triangle quality"],
  ["min", "quality/min", "q", 1],
  ["5th percentile", "quality/p5", "q", 1],
  ["mean", "quality/mean", "q", 1],
  ["share ≥ 0.91", "share_quality_ge_0.91", "pct", 1],
  ["Angles"],
  ["smallest", "min_angle/min", "deg", 1],
  ["largest", "max_angle/max", "deg", -1],
  ["under 30°", "share_below_30deg", "pct", -1],
  ["inverted", "inverted", "int", -1],
  ["Node fitness"],
  ["min", "fitness/min", "q", 1],
  ["mean", "fitness/mean", "q", 1],
];

/** A figure as the page shows it (the end-to-end test formats the API's numbers the same way). */
export function formatValue(value, kind) {
  if (value === null || value === undefined) return "–";
  if (kind === "int") return Math.round(value).toLocaleString("en-US");
  if (kind === "q") return value.toFixed(3);
  if (kind === "deg") return `${value.toFixed(1)}°`;
  if (kind === "pct") return `${(100 * value).toFixed(1)}%`;
  return String(value);
}

function dig(obj, path) {
  return path.split("/").reduce((o, k) => (o == null ? undefined : o[k]), obj);
}

function cell(tag, text, attrs = {}) {
  const el = document.createElement(tag);
  el.textContent = text;
  for (const [k, v] of Object.entries(attrs)) el.dataset[k] = v;
  return el;
}

export function renderSummary(box, doc) {
  const summary = doc.summary || {};
  const stages = STAGES.filter(([key]) => summary[key]);
  if (!stages.length && summary.mesh) stages.push(["mesh", "mesh"]);
  const table = document.createElement("table");
  const head = document.createElement("tr");
  head.append(cell("th", ""), ...stages.map(([, label]) => cell("th", label)));
  table.createTHead().append(head);
  const body = table.createTBody();
  for (const [label, path, kind, better] of ROWS) {
    const tr = body.insertRow();
    if (!path) {
      tr.className = "group";
      const td = cell("td", label);
      td.colSpan = stages.length + 1;
      tr.append(td);
      continue;
    }
    tr.append(cell("td", label));
    const first = dig(summary[stages[0][0]], path);
    stages.forEach(([key], i) => {
      const value = dig(summary[key], path);
      const td = cell("td", formatValue(value, kind), { stage: key, key: path });
      if (i === stages.length - 1 && i > 0 && better && typeof value === "number" && typeof first === "number") {
        const change = (value - first) * better;
        if (Math.abs(value - first) > 1e-9) td.className = change > 0 ? "better" : "worse";
      }
      tr.append(td);
    });
  }
  const parts = [table];
  const timings = summary.timings;
  if (timings) {
    const p = document.createElement("p");
    p.className = "timings";
    p.textContent =
      "time: " +
      Object.entries(timings)
        .map(([k, v]) => `${k} ${v < 0.01 ? v.toFixed(3) : v.toFixed(2)} s`)
        .join(" · ");
    parts.push(p);
  }
  const params = summary.parameters;
  if (params) {
    const p = document.createElement("p");
    p.className = "timings";
    const sizing = params.sizing || {};
    const smoothing = params.smoothing || {};
    const bits = [];
    if (sizing.size !== undefined) bits.push(`size ${sizing.size}`, `growth ${sizing.growth}`);
    if (params.swap !== undefined) bits.push(params.swap ? "swapped" : "no swapping");
    if (smoothing.method) bits.push(`smoothing ${smoothing.method}`);
    if (params.seed !== undefined) bits.push(`seed ${params.seed}`);
    p.textContent = bits.join(" · ");
    parts.push(p);
  }
  box.replaceChildren(...parts);
}

const FORMATS = [
  ["json", "JSON", "mesh document"],
  ["geojson", "GeoJSON", "triangles"],
  ["vtu", "VTU", "ParaView"],
  ["msh", "MSH", "Gmsh 2.2"],
  ["svg", "SVG", "picture"],
  ["png", "PNG", "picture"],
];

/** Links to every result format; with an API key they fetch with it and save the file. */
export function renderDownloads(box, jobId, { color, compare }) {
  const links = [];
  const add = (f, label, note, params) => {
    const a = document.createElement("a");
    a.href = resultUrl(jobId, params);
    a.download = `${jobId}${params.compare ? "-compare" : ""}.${f}`;
    a.dataset.format = f;
    a.append(label);
    const small = document.createElement("small");
    small.textContent = note;
    a.append(small);
    a.addEventListener("click", async (e) => {
      if (!apiKey()) return; // a plain link does
      e.preventDefault();
      const blob = await api.resultBlob(jobId, params);
      const href = URL.createObjectURL(blob);
      const tmp = Object.assign(document.createElement("a"), { href, download: a.download });
      tmp.click();
      setTimeout(() => URL.revokeObjectURL(href), 10000);
    });
    links.push(a);
  };
  for (const [f, label, note] of FORMATS) {
    const params = { f };
    if (f === "svg" || f === "png") params.color = color;
    add(f, label, note, params);
  }
  if (compare) {
    add("svg", "SVG", "before/after", { f: "svg", color, compare: "1" });
    add("png", "PNG", "before/after", { f: "png", color, compare: "1" });
  }
  box.replaceChildren(...links);
}
