// Drawing a region by clicking: the first ring is the outline, the rings after it are holes.
// Click the first corner (or double-click, or press Enter) to close a ring; Backspace undoes the
// last corner; Escape stops drawing. Each closed ring updates the region as a GeoJSON Polygon.

import { ringArea } from "./region.js";

const CLOSE_PX = 10; // how near the first corner a click closes the ring

export class DrawTool {
  /** @param {(polygon: object|null) => void} onChange called with the region after each ring */
  constructor(onChange) {
    this.onChange = onChange;
    this.rings = [];
    this.current = [];
    this.pointer = null;
  }

  /** Coordinates rounded to what the view can tell apart (a click is not more precise). */
  _round(v, view) {
    const digits = Math.max(0, Math.ceil(Math.log10(view.scale)) + 1);
    return Number(v.toFixed(Math.min(digits, 12)));
  }

  _nearFirst(px, py, view) {
    if (this.current.length < 3) return false;
    const [fx, fy] = view.toScreen(...this.current[0]);
    return Math.hypot(px - fx, py - fy) <= CLOSE_PX;
  }

  click(x, y, px, py, view) {
    if (this._nearFirst(px, py, view)) {
      this.closeRing(view);
      return;
    }
    this.current.push([this._round(x, view), this._round(y, view)]);
    view.invalidate();
  }

  doubleClick(view) {
    // The two clicks of a double-click each placed a corner at the same spot: keep one.
    const n = this.current.length;
    if (n >= 2) {
      const [a, b] = [this.current[n - 1], this.current[n - 2]];
      const [ax, ay] = view.toScreen(...a), [bx, by] = view.toScreen(...b);
      if (Math.hypot(ax - bx, ay - by) < CLOSE_PX) this.current.pop();
    }
    this.closeRing(view);
  }

  move(x, y, px, py, view) {
    this.pointer = { x, y, px, py };
    view.invalidate();
  }

  closeRing(view) {
    if (this.current.length < 3) return;
    const ring = this.current.slice();
    // GeoJSON's right-hand rule: the outline counter-clockwise, holes clockwise.
    const outer = this.rings.length === 0;
    if ((ringArea(ring) > 0) !== outer) ring.reverse();
    this.rings.push(ring);
    this.current = [];
    view.invalidate();
    this.onChange(this.polygon());
  }

  undo(view) {
    if (this.current.length) this.current.pop();
    else if (this.rings.length) {
      this.current = this.rings.pop();
      this.onChange(this.polygon());
    }
    view.invalidate();
  }

  polygon() {
    if (!this.rings.length) return null;
    return { type: "Polygon", coordinates: this.rings.map((r) => [...r, r[0]]) };
  }

  drawOverlay(ctx, view) {
    const path = (ring) => {
      ring.forEach(([x, y], i) => {
        const [sx, sy] = view.toScreen(x, y);
        if (i) ctx.lineTo(sx, sy);
        else ctx.moveTo(sx, sy);
      });
    };
    const dots = (ring, colour) => {
      ctx.fillStyle = colour;
      for (const [x, y] of ring) {
        const [sx, sy] = view.toScreen(x, y);
        ctx.beginPath();
        ctx.arc(sx, sy, 3, 0, 2 * Math.PI);
        ctx.fill();
      }
    };
    for (const ring of this.rings) dots(ring, "#1f2933");
    if (!this.current.length) return;
    ctx.beginPath();
    path(this.current);
    if (this.pointer) ctx.lineTo(this.pointer.px, this.pointer.py);
    ctx.strokeStyle = "#21918c";
    ctx.lineWidth = 2;
    ctx.setLineDash([6, 4]);
    ctx.stroke();
    ctx.setLineDash([]);
    dots(this.current, "#21918c");
    const closing = this.pointer && this._nearFirst(this.pointer.px, this.pointer.py, view);
    const [fx, fy] = view.toScreen(...this.current[0]);
    ctx.beginPath();
    ctx.arc(fx, fy, closing ? 9 : 6, 0, 2 * Math.PI);
    ctx.strokeStyle = "#21918c";
    ctx.lineWidth = 2;
    ctx.stroke();
  }
}
