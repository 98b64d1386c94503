"""The rules that choose a triangle for a slot: close the corner, bisect it, or build on the
shorter edge; new points go to an even share of a gap ahead, or onto the lattice."""

from __future__ import annotations

import math

import numba as nb

from ..quality import shape_quality_xy
from ..sizing import SizeTuple
from ..sizing import size_field_at as size_at
from .checks import candidates_near, front_clear, gap_ahead, wedge_ok
from .constants import (
    CLEAR_EDGE,
    CLEAR_VERTEX,
    CURVED,
    GAP_LAYERS,
    GAP_MIN_ROWS,
    LAYER,
    MADE,
    MERGE_RADIUS,
    NEXT,
    NO_MOVE,
    NO_ROOM,
    NP,
    PREV,
    Q_MIN,
    Q_MIN_RELAXED,
    RELAXED,
    SIZE,
    SNAP_CLEAR,
    SNAP_LAYER,
    SNAP_TOL,
    T_BISECT,
    T_CLOSE,
    T_CLOSE_RELAXED,
    VERT,
)  # fmt: skip
from .geometry import ccw, circumcircle
from .queue import slot_angle
from .slots import apply
from .state import Front, Heap, Index


@nb.njit(cache=True)
def try_apex(
    fr: Front, ix: Index, hp: Heap, sf: SizeTuple, e: int, px: float, py: float, d: float,
    q_min: float, allow_new: bool,
) -> int:  # fmt: skip
    """Triangle on the edge of slot ``e`` with the best apex near (px, py), new or existing.

    Returns MADE when a triangle was added, NO_MOVE when no candidate is valid, NO_ROOM when
    the arrays ran out of room.
    """
    slots, pts, cand = fr.slots, fr.pts, ix.cand
    t = slots[e, NEXT]
    u, v = slots[e, VERT], slots[t, VERT]
    ux, uy, vx, vy = pts[u, 0], pts[u, 1], pts[v, 0], pts[v, 1]
    tol = 1e-7 * d
    atol = 1e-9
    # Candidates: front vertices in the circumcircle of (u, v, P) or near P.
    ccx, ccy, rad = circumcircle(ux, uy, vx, vy, px, py)
    reach = max(1.05 * rad, math.hypot(ccx - px, ccy - py) + MERGE_RADIUS * d)
    n = candidates_near(fr, ix, ccx, ccy, reach)
    # The neighbours along the front are always candidates (closing a corner).
    if n < cand.shape[0]:
        cand[n] = slots[e, PREV]
        n += 1
    if n < cand.shape[0]:
        cand[n] = slots[t, NEXT]
        n += 1
    # Among valid existing apexes take the Delaunay one: the largest angle subtending u-v.
    best_k, best_a = -1, -1.0
    for i in range(n):
        k = cand[i]
        w = slots[k, VERT]
        if w in (u, v):
            continue
        wx, wy = pts[w, 0], pts[w, 1]
        ang = ccw(ux - wx, uy - wy, vx - wx, vy - wy)
        if ang >= math.pi or ang <= best_a:
            continue
        if shape_quality_xy(ux, uy, vx, vy, wx, wy) < q_min:
            continue
        if not wedge_ok(slots, pts, e, k, w, wx, wy, atol):
            continue
        if not front_clear(fr, ix, e, w, wx, wy, 0.0, 0.0, tol):
            continue
        best_k, best_a = k, ang
    new_ok = False
    if allow_new:
        # A new point only when no existing vertex lies in its circumcircle.
        ang_new = ccw(ux - px, uy - py, vx - px, vy - py)
        if shape_quality_xy(ux, uy, vx, vy, px, py) >= q_min and best_a < ang_new:
            new_ok = wedge_ok(slots, pts, e, -1, -1, px, py, atol) and front_clear(
                fr, ix, e, -1, px, py, CLEAR_EDGE * d, CLEAR_VERTEX * d, tol
            )
    if new_ok:
        w = fr.st[NP]
        pts[w, 0], pts[w, 1] = px, py
        pts[w, SIZE] = size_at(sf, px, py)
        fr.st[NP] += 1
        return MADE if apply(fr, ix, hp, e, -1, w) else NO_ROOM
    if best_k >= 0:
        return MADE if apply(fr, ix, hp, e, best_k, slots[best_k, VERT]) else NO_ROOM
    return NO_MOVE


@nb.njit(cache=True)
def snap(fr: Front, sf: SizeTuple, e: int, px: float, py: float) -> tuple[float, float]:
    """(px, py), or the nearest node of the region's lattice when the front of slot ``e``
    descends from a curved boundary, is ``SNAP_LAYER`` rows in and the size is uniform there.

    The lattice is equilateral with the field's size, rows along x from the lower left corner
    of the region's bounding box (the size field's origin). Fronts that follow a curve inward
    must shed nodes row after row (about 5.4 per row of a circle); re-anchored on one lattice
    their points stop being rows of the curve, and the interior becomes regular instead of
    dotted with five- and seven-neighbour pairs. Fronts from straight boundary are rows of
    their own lattice already; a global lattice at another angle would only add a seam where
    they meet it.
    """
    if fr.slots[e, CURVED] == 0 or fr.slots[e, LAYER] < SNAP_LAYER:
        return px, py
    h = sf[0]
    if size_at(sf, px, py) < h * (1.0 - 1e-9):
        return px, py
    ox, oy = sf[5], sf[6]
    rh = 0.5 * math.sqrt(3.0) * h
    j0 = math.floor((py - oy) / rh)
    best, bx, by = math.inf, px, py
    for j in range(j0, j0 + 2):
        off = 0.5 * h * (j % 2)
        i = math.floor((px - ox - off) / h + 0.5)
        x, y = ox + off + i * h, oy + j * rh
        d = (x - px) ** 2 + (y - py) ** 2
        if d < best:
            best, bx, by = d, x, y
    if best < (SNAP_TOL * h) ** 2:
        return bx, by
    return px, py


@nb.njit(cache=True)
def place(
    fr: Front, ix: Index, sf: SizeTuple, e: int, e2: int, s: int, ox: float, oy: float,
    dx: float, dy: float, step: float, scale: float,
) -> tuple[float, float, float]:  # fmt: skip
    """The new point ``step`` from (ox, oy) along the unit direction (dx, dy), for slot ``s``,
    and the step taken.

    When another front (not slot ``e``'s or ``e2``'s edge) lies less than ``GAP_LAYERS`` rows
    ahead, the rows left are spaced evenly: the step becomes ``gap / round(gap / step)``. The
    step is then multiplied by ``scale``; with no front within ``SNAP_CLEAR`` steps, the point
    may move onto the lattice (:func:`snap`).
    """
    reach = max(GAP_LAYERS, SNAP_CLEAR) * step
    gap = gap_ahead(fr, ix, e, e2, ox, oy, dx, dy, reach)
    rows = math.floor(gap / step + 0.5)
    if gap < GAP_LAYERS * step and rows >= GAP_MIN_ROWS:
        step = gap / rows
    step *= scale
    px, py = ox + dx * step, oy + dy * step
    if gap >= SNAP_CLEAR * step:
        px, py = snap(fr, sf, s, px, py)
    return px, py, step


@nb.njit(cache=True)
def ideal_apex(
    fr: Front, ix: Index, sf: SizeTuple, e: int, scale: float
) -> tuple[float, float, float]:
    """Apex of a near-equilateral triangle on the edge of slot ``e`` for the local size.

    When another front lies ahead closer than ``GAP_LAYERS`` rows, the rows left between them
    are spaced evenly: the apex goes to ``gap / round(gap / height)``, so two fronts meeting
    across a gap that is not a whole number of rows close with evenly stretched triangles
    instead of a last row of slivers.
    """
    slots, pts = fr.slots, fr.pts
    u, v = slots[e, VERT], slots[slots[e, NEXT], VERT]
    ux, uy, vx, vy = pts[u, 0], pts[u, 1], pts[v, 0], pts[v, 1]
    length = math.hypot(vx - ux, vy - uy)
    nx_, ny_ = -(vy - uy) / length, (vx - ux) / length
    mx, my = 0.5 * (ux + vx), 0.5 * (uy + vy)
    h = 0.5 * (pts[u, SIZE] + pts[v, SIZE])
    h_far = size_at(sf, mx + nx_ * 0.866 * h, my + ny_ * 0.866 * h)
    delta = min(max(0.5 * (h + h_far), 0.55 * length), 1.6 * length)
    height = math.sqrt(max(delta * delta - 0.25 * length * length, 0.09 * length * length))
    px, py, _ = place(fr, ix, sf, e, e, e, mx, my, nx_, ny_, height, scale)
    return px, py, delta


@nb.njit(cache=True)
def process(fr: Front, ix: Index, hp: Heap, sf: SizeTuple, s: int) -> int:
    """Advance the front at slot ``s`` (the smallest angle); MADE, NO_MOVE or NO_ROOM."""
    slots, pts = fr.slots, fr.pts
    ps, ns = slots[s, PREV], slots[s, NEXT]
    a, b, c = slots[ps, VERT], slots[s, VERT], slots[ns, VERT]
    ax, ay, bx, by, cx, cy = pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1], pts[c, 0], pts[c, 1]
    la = math.hypot(ax - bx, ay - by)
    lc = math.hypot(cx - bx, cy - by)
    theta = slot_angle(fr, s)
    relaxed = fr.st[RELAXED] > 0
    q_min = Q_MIN_RELAXED if relaxed else Q_MIN
    close_limit = T_CLOSE_RELAXED if relaxed else T_CLOSE
    if theta < close_limit:
        r = try_apex(fr, ix, hp, sf, ps, cx, cy, max(la, lc), q_min, False)
        if r != NO_MOVE:
            return r
    if theta < T_BISECT:
        # A new point on the bisector splits the corner into two triangles.
        half = 0.5 * theta
        dx, dy = (cx - bx) / lc, (cy - by) / lc
        bis_x = dx * math.cos(half) - dy * math.sin(half)
        bis_y = dx * math.sin(half) + dy * math.cos(half)
        h0 = pts[b, SIZE]
        d = 0.5 * (h0 + size_at(sf, bx + bis_x * h0, by + bis_y * h0))
        lavg = 0.5 * (la + lc)
        d = min(max(d, 0.7 * lavg), 1.4 * lavg)
        qx, qy, d = place(fr, ix, sf, ps, s, s, bx, by, bis_x, bis_y, d, 1.0)
        r = try_apex(fr, ix, hp, sf, ps, qx, qy, d, q_min, True)
        if r != NO_MOVE:
            return r
        if close_limit <= theta < T_CLOSE_RELAXED:
            r = try_apex(fr, ix, hp, sf, ps, cx, cy, max(la, lc), q_min, False)
            if r != NO_MOVE:
                return r
    scales = (1.0, 0.6, 0.35) if relaxed else (1.0, 1.0, 1.0)
    for i in range(3 if relaxed else 1):
        for attempt in range(2):
            e = s if (lc <= la) == (attempt == 0) else ps
            px, py, d = ideal_apex(fr, ix, sf, e, scales[i])
            r = try_apex(fr, ix, hp, sf, e, px, py, d, q_min, True)
            if r != NO_MOVE:
                return r
    return NO_MOVE
