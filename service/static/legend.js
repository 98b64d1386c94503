// What the legend and the readout say about the mesh shown: the colour range people set, the
// tagged lines' names, and the figures of the triangle under the pointer.

import { namesById } from "./meshdata.js";
import { TAG_COLORS } from "./view.js";

/** The colour range's min and max inputs: per metric, empty ends take the data's range. */
export class ColourRange {
  constructor(lo, hi, reset, onChange) {
    this.inputs = [lo, hi];
    this.ranges = {}; // metric -> [lo, hi], null ends: the data's
    this.metric = null;
    const read = () => {
      const end = (input) => (input.value.trim() === "" || !Number.isFinite(Number(input.value)) ? null : Number(input.value));
      this.ranges[this.metric] = this.inputs.map(end);
      onChange();
    };
    for (const input of this.inputs) input.addEventListener("change", read);
    reset.addEventListener("click", () => {
      delete this.ranges[this.metric];
      onChange();
    });
  }

  /** Forget every range set (a new job: its data's ranges). */
  clear() {
    this.ranges = {};
  }

  /** The range to colour a metric over, given the data's [lo, hi]; shows both in the inputs. */
  apply(metric, lo, hi) {
    this.metric = metric;
    const set = this.ranges[metric] || [null, null];
    const data = [lo, hi];
    this.inputs.forEach((input, i) => {
      input.placeholder = data[i].toFixed(2);
      if (document.activeElement !== input) input.value = set[i] === null ? "" : String(set[i]);
    });
    const range = [set[0] ?? lo, set[1] ?? hi];
    return range[0] === range[1] ? data : range; // an empty range colours nothing
  }
}

/** One coloured name per tag drawn on the mesh (the overlay's colours). */
export function renderTagLegend(box, mesh, tags) {
  box.replaceChildren();
  if (!mesh.lines) return;
  const names = namesById(tags);
  for (const id of [...new Set(mesh.lineTag)].sort((a, b) => a - b)) {
    const span = document.createElement("span");
    span.textContent = names.get(id) || `#${id}`;
    span.style.color = TAG_COLORS[(id - 1) % TAG_COLORS.length];
    box.append(span);
  }
}

/** The readout of the point (x, y) over triangle t (-1: none) of a mesh (or null). */
export function readoutText({ x, y, t }, mesh, display, colorBy) {
  let text;
  if (display) {
    const [lon, lat] = display.inverse(x, y);
    text = `lon ${lon.toFixed(5)}°  lat ${lat.toFixed(5)}°`;
  } else {
    text = `x ${x.toPrecision(5)}  y ${y.toPrecision(5)}`;
  }
  if (mesh && t >= 0) {
    const q = mesh.cell.quality[t];
    text = `${display ? `${text} · ` : ""}triangle ${t.toLocaleString("en-US")} · quality ${q.toFixed(3)}`;
    if (mesh.cell.min_angle) {
      text += ` · angles ${mesh.cell.min_angle[t].toFixed(1)}°–${mesh.cell.max_angle[t].toFixed(1)}°`;
    }
    if (colorBy === "fitness" && mesh.node.fitness) {
      const p = mesh.nearestCorner(t, x, y);
      text += ` · node ${p} fitness ${mesh.node.fitness[p].toFixed(3)}`;
    }
  }
  return text;
}
