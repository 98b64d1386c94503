// Coordinate reference systems in the viewer: the choices offered, which codes are lon/lat, and
// how lon/lat is drawn. The service does the projecting (pyproj); the page only needs to send the
// code, label sizes in metres for lon/lat, and draw lon/lat true to shape.

const EARTH_RADIUS_M = 6371008.8;
const METRES_PER_DEGREE = (Math.PI / 180) * EARTH_RADIUS_M;

/** Geographic (lon/lat, degrees) codes the page recognises; any other code is taken as projected. */
const GEOGRAPHIC = new Set([
  "WGS84", "OGC:CRS84", "CRS84", "EPSG:4326", "EPSG:4258", "EPSG:4269", "EPSG:4283", "EPSG:4167",
  "EPSG:4612", "EPSG:6668", "EPSG:4490", "EPSG:7844", "EPSG:4617", "EPSG:4674", "EPSG:4979",
]);

/** A code as the page compares them: trimmed, upper case, OGC URNs and URLs to AUTH:CODE. */
export function normalizeCode(text) {
  const code = String(text || "").trim().toUpperCase();
  const urn = /^URN:OGC:DEF:CRS:([A-Z]+):[^:]*:(\w+)$/.exec(code);
  if (urn) return `${urn[1]}:${urn[2]}`;
  const url = /OPENGIS\.NET\/DEF\/CRS\/([A-Z]+)\/[^/]*\/(\w+)$/.exec(code);
  if (url) return `${url[1]}:${url[2]}`;
  return code;
}

/** Whether a CRS code means lon/lat in degrees ("" is planar, no CRS). */
export function isGeographic(code) {
  return GEOGRAPHIC.has(normalizeCode(code));
}

/** The input CRS of a result document ("" when planar); `crs` is a code or {input, mesh, ...}. */
export function crsOf(doc) {
  const crs = doc && doc.crs;
  if (!crs) return "";
  if (typeof crs === "string") return crs;
  return crs.input || crs.source || "";
}

/** The WGS 84 UTM zone code of a lon/lat position (EPSG:326zz north, EPSG:327zz south). */
export function utmCode(lon, lat) {
  const zone = (((Math.floor((lon + 180) / 6) % 60) + 60) % 60) + 1;
  return `EPSG:${lat < 0 ? 327 : 326}${String(zone).padStart(2, "0")}`;
}

/**
 * The CRS codes offered in the form: lon/lat and, for a region whose positions [[x, y], ...]
 * could be lon/lat, the UTM zone of its centre. Any other code can be typed; empty is planar.
 */
export function crsChoices(points) {
  const out = [
    { value: "EPSG:4326", label: "lon/lat, WGS 84 (GeoJSON)" },
    { value: "OGC:CRS84", label: "lon/lat, WGS 84 (OGC CRS84)" },
    { value: "EPSG:3857", label: "Web Mercator (metres, not true to size)" },
  ];
  if (points.length && points.every((p) => Math.abs(p[0]) <= 180 && Math.abs(p[1]) <= 90)) {
    const { lon0, lat0 } = LonLatDisplay.of(points);
    const code = utmCode(lon0, lat0);
    const zone = Number(code.slice(-2));
    out.splice(2, 0, { value: code, label: `UTM zone ${zone}${lat0 < 0 ? "S" : "N"} (metres)` });
  }
  return out;
}

/**
 * Draws lon/lat true to shape near its centre: x = longitude * cos(latitude of the centre), y =
 * latitude, longitudes kept continuous across the antimeridian. `inverse` gives lon/lat back.
 */
export class LonLatDisplay {
  constructor(lon0, lat0) {
    this.lon0 = lon0;
    this.lat0 = lat0;
    this.k = Math.max(Math.cos((lat0 * Math.PI) / 180), 1e-3);
  }

  /** The display for the positions [[lon, lat], ...], centred on their box. */
  static of(points) {
    if (!points.length) return new LonLatDisplay(0, 0);
    const ref = points[0][0];
    let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    for (const p of points) {
      const lon = unwrap(p[0], ref);
      x0 = Math.min(x0, lon); x1 = Math.max(x1, lon);
      y0 = Math.min(y0, p[1]); y1 = Math.max(y1, p[1]);
    }
    // The box's middle, not the mean: a region and its mesh then get the same display.
    return new LonLatDisplay((x0 + x1) / 2, (y0 + y1) / 2);
  }

  forward(p) {
    return [unwrap(p[0], this.lon0) * this.k, p[1]];
  }

  inverse(x, y) {
    return [wrap(x / this.k), y];
  }
}

function unwrap(lon, ref) {
  return lon - 360 * Math.round((lon - ref) / 360);
}

function wrap(lon) {
  return lon - 360 * Math.round(lon / 360);
}

/** A copy of a mesh document (and its `initial`) with lon/lat points mapped for display. */
export function forDisplay(doc, display) {
  const map = (part) => ({ ...part, points: part.points.map((p) => display.forward(p)) });
  const out = map(doc);
  if (doc.initial) out.initial = map(doc.initial);
  return out;
}

/** Region parts [[ring, ...], ...] of lon/lat mapped for display. */
export function partsForDisplay(parts, display) {
  return parts.map((rings) => rings.map((ring) => ring.map((p) => display.forward(p))));
}

/** Square metres per square display unit (lon * cos(lat0) by lat degrees). */
export const SQUARE_METRES_PER_UNIT = METRES_PER_DEGREE * METRES_PER_DEGREE;
