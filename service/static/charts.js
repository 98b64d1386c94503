// Small charts: the quality histograms (before and after, log-scale counts, as in the pictures)
// and the colour bar of the legend.

import { VIRIDIS, WORST, cssColorAt } from "./colormap.js";

export const HISTOGRAM_BINS = 30;

/** Triangle counts in HISTOGRAM_BINS equal bins over [lo, 1]. */
export function histogram(values, lo) {
  const counts = new Uint32Array(HISTOGRAM_BINS);
  const width = (1 - lo) / HISTOGRAM_BINS;
  for (let i = 0; i < values.length; i++) {
    const b = Math.floor((Math.min(Math.max(values[i], lo), 1) - lo) / width);
    counts[Math.min(HISTOGRAM_BINS - 1, Math.max(0, b))]++;
  }
  return counts;
}

function sized(canvas) {
  const dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth || canvas.width, h = canvas.clientHeight || canvas.height;
  canvas.width = Math.round(w * dpr);
  canvas.height = Math.round(h * dpr);
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  return [ctx, w, h];
}

/**
 * Draw the histogram of `values` (bars) over that of `other` (dashed), on [lo, 1] with a log
 * count axis topping at `top` triangles. Empty `values` clear the chart.
 */
export function drawHistogram(canvas, values, other, lo, top, otherName) {
  const [ctx, w, h] = sized(canvas);
  if (!values || !values.length) return;
  const left = 30, right = 6, topPad = 12, bottom = 16;
  const pw = w - left - right, ph = h - topPad - bottom;
  const maxLog = Math.log10(Math.max(10, top) * 2);
  const yOf = (count) => topPad + ph - (count > 0 ? ((Math.log10(count) + 0.15) / (maxLog + 0.15)) * ph : 0);
  const xOf = (v) => left + ((v - lo) / (1 - lo)) * pw;
  ctx.font = "10px system-ui, sans-serif";
  ctx.textBaseline = "middle";
  // Decades of the count axis.
  ctx.strokeStyle = "#eef1f4";
  ctx.fillStyle = "#9aa5b1";
  ctx.lineWidth = 1;
  for (let d = 0; d <= Math.floor(maxLog); d++) {
    const y = yOf(10 ** d);
    ctx.beginPath(); ctx.moveTo(left, y); ctx.lineTo(left + pw, y); ctx.stroke();
    ctx.textAlign = "right";
    ctx.fillText(d < 3 ? String(10 ** d) : `1e${d}`, left - 4, y);
  }
  const counts = histogram(values, lo);
  const bw = pw / HISTOGRAM_BINS;
  for (let b = 0; b < HISTOGRAM_BINS; b++) {
    if (!counts[b]) continue;
    ctx.fillStyle = cssColorAt((b + 0.5) / HISTOGRAM_BINS);
    const y = yOf(counts[b]);
    ctx.fillRect(left + b * bw + 0.5, y, bw - 1, topPad + ph - y);
  }
  if (other && other.length) {
    const oc = histogram(other, lo);
    ctx.strokeStyle = "#1f2933";
    ctx.setLineDash([3, 2]);
    ctx.beginPath();
    for (let b = 0; b < HISTOGRAM_BINS; b++) {
      const y = yOf(oc[b]);
      if (b) ctx.lineTo(left + b * bw, y);
      else ctx.moveTo(left, y);
      ctx.lineTo(left + (b + 1) * bw, y);
    }
    ctx.stroke();
    ctx.setLineDash([]);
    ctx.textAlign = "right";
    ctx.fillStyle = "#6b7683";
    ctx.fillText(`dashed: ${otherName}`, left + pw, 5);
  }
  let min = Infinity;
  for (let i = 0; i < values.length; i++) min = Math.min(min, values[i]);
  const mx = xOf(min);
  ctx.strokeStyle = WORST;
  ctx.beginPath(); ctx.moveTo(mx, topPad); ctx.lineTo(mx, topPad + ph); ctx.stroke();
  ctx.fillStyle = WORST;
  ctx.textAlign = mx > left + pw * 0.7 ? "right" : "left";
  ctx.fillText(`min ${min.toFixed(3)}`, mx + (ctx.textAlign === "left" ? 3 : -3), topPad + 4);
  // Quality axis.
  ctx.strokeStyle = "#c5ccd3";
  ctx.beginPath(); ctx.moveTo(left, topPad + ph + 0.5); ctx.lineTo(left + pw, topPad + ph + 0.5); ctx.stroke();
  ctx.fillStyle = "#6b7683";
  ctx.textBaseline = "top";
  for (const [v, align] of [[lo, "left"], [(lo + 1) / 2, "center"], [1, "right"]]) {
    ctx.textAlign = align;
    ctx.fillText(v.toFixed(2), xOf(v), topPad + ph + 3);
  }
}

/** The legend's colour bar: the map from left (bad) to right (ideal). */
export function drawColorBar(canvas) {
  const ctx = canvas.getContext("2d");
  const image = ctx.createImageData(canvas.width, canvas.height);
  for (let x = 0; x < canvas.width; x++) {
    const i = Math.round((x / (canvas.width - 1)) * 255);
    for (let y = 0; y < canvas.height; y++) {
      image.data.set([VIRIDIS[3 * i], VIRIDIS[3 * i + 1], VIRIDIS[3 * i + 2], 255], 4 * (y * canvas.width + x));
    }
  }
  ctx.putImageData(image, 0, 0);
}
