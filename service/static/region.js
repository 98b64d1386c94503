// Regions as the page sees them before the service does: the rings of pasted or drawn GeoJSON
// (or {outer, holes}) for the preview, their area for a size suggestion, and the examples.
// The service validates for real; this only reads enough to draw and to estimate.

/** Area of an equilateral triangle of unit side: a region of area A meshed at size h holds
 * about A / (EQUILATERAL h^2) triangles (the service estimates the same way). */
const EQUILATERAL = Math.sqrt(3) / 4;

function isPosition(p) {
  return Array.isArray(p) && p.length >= 2 && p.every((c) => typeof c === "number" && Number.isFinite(c));
}

function isRing(r) {
  return Array.isArray(r) && r.length >= 3 && r.every(isPosition);
}

function polygonParts(geometry, where) {
  if (!geometry || typeof geometry !== "object") throw new Error(`${where}: no geometry`);
  if (geometry.type === "Polygon") return [rings(geometry.coordinates, where)];
  if (geometry.type === "MultiPolygon") {
    if (!Array.isArray(geometry.coordinates)) throw new Error(`${where}: coordinates missing`);
    return geometry.coordinates.map((c, i) => rings(c, `${where} polygon ${i}`));
  }
  throw new Error(`${where}: unsupported type ${JSON.stringify(geometry.type)}`);
}

function rings(coords, where) {
  if (!Array.isArray(coords) || !coords.length) throw new Error(`${where}: no rings`);
  coords.forEach((r, i) => {
    if (!isRing(r)) throw new Error(`${where}: ring ${i} needs 3 or more [x, y] positions`);
  });
  return coords.map((r) => r.map((p) => [p[0], p[1]]));
}

/**
 * Read a region. Returns {parts: [[outer, hole, ...], ...], properties, kind}; throws Error with
 * a message fit for the page when the text is not a region.
 */
export function parseRegion(text) {
  const obj = typeof text === "string" ? JSON.parse(text) : text;
  if (Array.isArray(obj)) return { parts: [rings(obj, "rings")], properties: {}, kind: "rings" };
  if (!obj || typeof obj !== "object") throw new Error("not a JSON object");
  if ("outer" in obj) {
    if (!isRing(obj.outer)) throw new Error("outer needs 3 or more [x, y] positions");
    const holes = obj.holes || [];
    if (!Array.isArray(holes)) throw new Error("holes must be a list of rings");
    return { parts: [rings([obj.outer, ...holes], "region")], properties: {}, kind: "outer/holes" };
  }
  if (obj.type === "Feature") {
    return { parts: polygonParts(obj.geometry, "feature"), properties: obj.properties || {}, kind: "Feature" };
  }
  if (obj.type === "FeatureCollection") {
    if (!Array.isArray(obj.features) || !obj.features.length) throw new Error("no features");
    const parts = obj.features.flatMap((f, i) => polygonParts(f && f.geometry, `feature ${i}`));
    return { parts, properties: (obj.features[0] && obj.features[0].properties) || {}, kind: "FeatureCollection" };
  }
  return { parts: polygonParts(obj, "geometry"), properties: {}, kind: obj.type };
}

/** Signed area of a ring (shoelace). */
export function ringArea(ring) {
  let a = 0;
  for (let i = 0, j = ring.length - 1; i < ring.length; j = i++) {
    a += (ring[j][0] + ring[i][0]) * (ring[j][1] - ring[i][1]);
  }
  return -a / 2;
}

/** Figures of a parsed region: rings, vertices, area, bounding box. */
export function regionStats(region) {
  let rings = 0, vertices = 0, area = 0;
  const box = [Infinity, Infinity, -Infinity, -Infinity];
  for (const part of region.parts) {
    part.forEach((ring, i) => {
      rings += 1;
      vertices += ring.length;
      area += (i === 0 ? 1 : -1) * Math.abs(ringArea(ring));
      for (const [x, y] of ring) {
        box[0] = Math.min(box[0], x); box[1] = Math.min(box[1], y);
        box[2] = Math.max(box[2], x); box[3] = Math.max(box[3], y);
      }
    });
  }
  return { rings, vertices, area: Math.max(area, 0), box };
}

/** About how many triangles a region of `area` gives at edge length `size`. */
export function estimateTriangles(area, size) {
  return size > 0 ? Math.ceil(area / (EQUILATERAL * size * size)) : Infinity;
}

/** A round size that gives about `target` triangles. */
export function suggestSize(area, target = 3000) {
  if (!(area > 0)) return 0.1;
  const h = Math.sqrt(area / (EQUILATERAL * target));
  const p = 10 ** Math.floor(Math.log10(h));
  return Number((Math.round(h / p) * p).toPrecision(2));
}

function circle(cx, cy, r, n, clockwise = false) {
  const ring = [];
  for (let i = 0; i < n; i++) {
    const t = ((clockwise ? -1 : 1) * 2 * Math.PI * i) / n;
    ring.push([+(cx + r * Math.cos(t)).toFixed(6), +(cy + r * Math.sin(t)).toFixed(6)]);
  }
  ring.push(ring[0]);
  return ring;
}

function feature(name, coordinates, h) {
  return { type: "Feature", properties: { name, h }, geometry: { type: "Polygon", coordinates } };
}

/** Regions to start from. */
export const EXAMPLES = {
  "L-shape": feature("L-shape", [[[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2], [0, 0]]], 0.05),
  "Plate with a hole": feature(
    "plate with a hole",
    [[[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]], circle(0, 0, 0.3, 48, true)],
    0.05,
  ),
  Annulus: feature("annulus", [circle(0, 0, 1, 96), circle(0, 0, 0.45, 48, true)], 0.05),
  "Channel with two obstacles": feature(
    "channel",
    [
      [[0, 0], [4, 0], [4, 1], [0, 1], [0, 0]],
      circle(1, 0.5, 0.2, 40, true),
      [[2.6, 0.35], [2.6, 0.65], [2.9, 0.65], [2.9, 0.35], [2.6, 0.35]],
    ],
    0.04,
  ),
  "Unit square": { type: "Polygon", coordinates: [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]] },
};
