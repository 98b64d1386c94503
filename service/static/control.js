// A job's mesh control drawn over its mesh: the refinements (dashed, orange) and the constraints
// (solid, purple), each an overlay layer the legend switches on and off.
//
// Where they come from: a planar or projected result carries them in its summary's parameters
// (sizing.refinements, constraints: in its own coordinates). A lon/lat result's parameters are in
// its meshing plane (metres), which the page cannot map back; the inputs this browser sent for
// the job (lon/lat) are drawn instead, when it has them.

import { recall } from "./rerun.js";

/** Overlay layers, in legend order: name -> {colour, label}. */
export const LAYERS = {
  refinements: { color: "#e8710a", label: "refinements" },
  constraints: { color: "#6a3d9a", label: "constraints" },
};

/** The GeoJSON geometries of a constraints input (a geometry, Feature or FeatureCollection). */
function geometriesOf(obj) {
  if (!obj || typeof obj !== "object") return [];
  if (obj.type === "FeatureCollection") return (obj.features || []).flatMap(geometriesOf);
  if (obj.type === "Feature") return obj.geometry ? [obj.geometry] : [];
  return [obj];
}

/** `geometry` with every position mapped by `map` (a [x, y] -> [x, y] function). */
function mapGeometry(geometry, map) {
  if (geometry.type === "GeometryCollection") {
    return { ...geometry, geometries: geometry.geometries.map((g) => mapGeometry(g, map)) };
  }
  const walk = (c) => (typeof c[0] === "number" ? map(c) : c.map(walk));
  return { ...geometry, coordinates: walk(geometry.coordinates) };
}

/** The refinements ({geometry, size}) and constraints (geometries) of a job, in view coordinates. */
export function controlOf(id, doc, display) {
  let refinements = [];
  let constraints = [];
  const used = (doc.summary && doc.summary.parameters) || {};
  if (!display) {
    refinements = (used.sizing && used.sizing.refinements) || [];
    constraints = used.constraints || [];
  } else {
    const asked = recall(id);
    const inputs = (asked && asked.inputs) || {};
    refinements = inputs.refinements || [];
    constraints = geometriesOf(inputs.constraints);
  }
  const map = display ? (p) => display.forward(p) : (p) => p;
  return {
    refinements: refinements.filter((r) => r && r.geometry).map((r) => ({ size: r.size, geometry: mapGeometry(r.geometry, map) })),
    constraints: constraints.filter((g) => g && g.type).map((g) => mapGeometry(g, map)),
  };
}

/** A button per layer the job has, switching it on and off in the view. */
export function renderLayerToggles(box, view) {
  box.replaceChildren();
  const control = view.control;
  if (!control) return;
  for (const [name, { color, label }] of Object.entries(LAYERS)) {
    const count = control[name].length;
    if (!count) continue;
    const button = document.createElement("button");
    button.type = "button";
    button.dataset.layer = name;
    button.textContent = `${label} (${count})`;
    button.style.color = color;
    button.classList.toggle("on", view.layers[name]);
    button.title = `show or hide the job's ${label}`;
    button.addEventListener("click", () => {
      view.setLayer(name, !view.layers[name]);
      button.classList.toggle("on", view.layers[name]);
    });
    box.append(button);
  }
}

/** Draw a GeoJSON geometry on a 2D context through `toScreen`; how many shapes it drew. */
export function drawGeometry(ctx, geometry, toScreen, pointRadius) {
  const path = (line, close) => {
    line.forEach(([x, y], i) => {
      const [sx, sy] = toScreen(x, y);
      if (i) ctx.lineTo(sx, sy);
      else ctx.moveTo(sx, sy);
    });
    if (close) ctx.closePath();
  };
  const dot = ([x, y]) => {
    const [sx, sy] = toScreen(x, y);
    ctx.beginPath();
    ctx.arc(sx, sy, pointRadius, 0, 2 * Math.PI);
    ctx.stroke();
  };
  const c = geometry.coordinates;
  switch (geometry.type) {
    case "Point": dot(c); return 1;
    case "MultiPoint": c.forEach(dot); return c.length;
    case "LineString": ctx.beginPath(); path(c, false); ctx.stroke(); return 1;
    case "MultiLineString": ctx.beginPath(); c.forEach((l) => path(l, false)); ctx.stroke(); return c.length;
    case "Polygon": ctx.beginPath(); c.forEach((r) => path(r, true)); ctx.stroke(); return 1;
    case "MultiPolygon": ctx.beginPath(); c.forEach((p) => p.forEach((r) => path(r, true))); ctx.stroke(); return c.length;
    case "GeometryCollection":
      return geometry.geometries.reduce((n, g) => n + drawGeometry(ctx, g, toScreen, pointRadius), 0);
    default: return 0;
  }
}
