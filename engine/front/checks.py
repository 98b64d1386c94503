"""Validity of a candidate triangle against the front, and the front queries the rules use."""

from __future__ import annotations

import math

from .constants import NEXT, PREV, TWO_PI, VERT
from .geometry import ccw, orient, seg_dist2, segments_meet
from .index import gather
from .state import FloatArray, Front, Index, IntArray, uncounted


@uncounted()
def wedge_ok(
    slots: IntArray, pts: FloatArray, e: int, k: int, w: int, wx: float, wy: float, tol: float
) -> bool:
    """Corners of the triangle (u, v, w) on slot ``e``'s edge at u, v (and at the apex slot
    ``k``, if any) lie in the front's wedges."""
    t = slots[e, NEXT]
    u, v = slots[e, VERT], slots[t, VERT]
    pu, nv = slots[slots[e, PREV], VERT], slots[slots[t, NEXT], VERT]
    ux, uy, vx, vy = pts[u, 0], pts[u, 1], pts[v, 0], pts[v, 1]
    if w != pu:
        wedge = ccw(vx - ux, vy - uy, pts[pu, 0] - ux, pts[pu, 1] - uy)
        if wedge <= 0.0:
            wedge = TWO_PI
        phi = ccw(vx - ux, vy - uy, wx - ux, wy - uy)
        if not (tol < phi < wedge - tol):
            return False
    if w != nv:
        wedge = ccw(pts[nv, 0] - vx, pts[nv, 1] - vy, ux - vx, uy - vy)
        if wedge <= 0.0:
            wedge = TWO_PI
        phi = ccw(pts[nv, 0] - vx, pts[nv, 1] - vy, wx - vx, wy - vy)
        if not (tol < phi < wedge - tol):
            return False
    if k >= 0:
        nw, pw = slots[slots[k, NEXT], VERT], slots[slots[k, PREV], VERT]
        bx, by = pts[nw, 0] - wx, pts[nw, 1] - wy
        wedge = ccw(bx, by, pts[pw, 0] - wx, pts[pw, 1] - wy)
        if wedge <= 0.0:
            wedge = TWO_PI
        phi_u = 0.0 if u == nw else ccw(bx, by, ux - wx, uy - wy)
        phi_v = wedge if v == pw else ccw(bx, by, vx - wx, vy - wy)
        if u != nw and phi_u <= tol:
            return False
        if v != pw and phi_v >= wedge - tol:
            return False
        if phi_u >= phi_v:
            return False
    return True


@uncounted()
def front_clear(
    fr: Front, ix: Index, e: int, w: int, wx: float, wy: float,
    clear_edge: float, clear_vertex: float, tol: float,
) -> bool:  # fmt: skip
    """No front edge crosses the new edges of triangle (u, v, w) on slot ``e``'s edge and no
    front vertex lies in it.

    With ``w < 0`` (a new point), front edges and vertices must also keep ``clear_edge`` /
    ``clear_vertex`` away from it.
    """
    slots, pts = fr.slots, fr.pts
    t = slots[e, NEXT]
    u, v = slots[e, VERT], slots[t, VERT]
    pu, nv = slots[slots[e, PREV], VERT], slots[slots[t, NEXT], VERT]
    ux, uy, vx, vy = pts[u, 0], pts[u, 1], pts[v, 0], pts[v, 1]
    margin = max(clear_edge, clear_vertex) + tol
    x0 = min(ux, vx, wx) - margin
    x1 = max(ux, vx, wx) + margin
    y0 = min(uy, vy, wy) - margin
    y1 = max(uy, vy, wy) + margin
    new_uw = w != pu  # edge u-w is new (not already the front edge w -> u)
    new_wv = w != nv
    ce2, cv2 = clear_edge * clear_edge, clear_vertex * clear_vertex
    # Tolerances of the triangle's sides for the vertex test, computed once when first needed.
    lu = lv = lw = -1.0
    hits = ix.hits
    for h in range(gather(fr, ix, x0, y0, x1, y1)):
        f = hits[h]
        if f == e:
            continue
        a, b = slots[f, VERT], slots[slots[f, NEXT], VERT]
        ax, ay, bx, by = pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1]
        apart_u = a != u and b != u and a != w and b != w
        if new_uw and apart_u and segments_meet(ux, uy, wx, wy, ax, ay, bx, by, tol):
            return False
        apart_v = a != v and b != v and a != w and b != w
        if new_wv and apart_v and segments_meet(wx, wy, vx, vy, ax, ay, bx, by, tol):
            return False
        if a != u and a != v and a != w:
            # A front vertex inside (or on) the triangle.
            if lu < 0.0:
                lu = tol * math.hypot(vx - ux, vy - uy)
                lv = tol * math.hypot(wx - vx, wy - vy)
                lw = tol * math.hypot(ux - wx, uy - wy)
            if (
                orient(ux, uy, vx, vy, ax, ay) > -lu
                and orient(vx, vy, wx, wy, ax, ay) > -lv
                and orient(wx, wy, ux, uy, ax, ay) > -lw
            ):
                return False
        if w < 0:
            if (ax - wx) ** 2 + (ay - wy) ** 2 < cv2:
                return False
            if seg_dist2(wx, wy, ax, ay, bx, by) < ce2:
                return False
    return True


@uncounted()
def candidates_near(fr: Front, ix: Index, px: float, py: float, r: float) -> int:
    """Write the front slots whose vertex lies within ``r`` of (px, py) to ``ix.cand``;
    returns how many."""
    slots, pts, out = fr.slots, fr.pts, ix.cand
    n = 0
    hits = ix.hits
    for h in range(gather(fr, ix, px - r, py - r, px + r, py + r)):
        f = hits[h]
        a = slots[f, VERT]
        if (pts[a, 0] - px) ** 2 + (pts[a, 1] - py) ** 2 <= r * r and n < out.shape[0]:
            out[n] = f
            n += 1
    return n


@uncounted()
def gap_ahead(
    fr: Front, ix: Index, e: int, e2: int, mx: float, my: float, dx: float, dy: float,
    reach: float,
) -> float:  # fmt: skip
    """Distance from (mx, my) along the unit direction (dx, dy) to the first front edge other
    than those of slots ``e`` and ``e2``, or ``reach`` when none is that close."""
    slots, pts = fr.slots, fr.pts
    ex, ey = mx + dx * reach, my + dy * reach
    best = reach
    hits = ix.hits
    for h in range(gather(fr, ix, min(mx, ex), min(my, ey), max(mx, ex), max(my, ey))):
        f = hits[h]
        if f in (e, e2):
            continue
        a, b = slots[f, VERT], slots[slots[f, NEXT], VERT]
        sx, sy = pts[b, 0] - pts[a, 0], pts[b, 1] - pts[a, 1]
        denom = dx * sy - dy * sx
        if abs(denom) <= 1e-12 * math.hypot(sx, sy):
            continue
        wx, wy = pts[a, 0] - mx, pts[a, 1] - my
        t = (wx * sy - wy * sx) / denom
        r = (wx * dy - wy * dx) / denom
        if 0.0 <= r <= 1.0 and 1e-9 * reach < t < best:
            best = t
    return best
