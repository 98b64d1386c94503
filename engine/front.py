"""Advancing-front triangulation, smallest front angle first.

The front is a set of closed loops of *slots*; slot ``s`` stands at vertex ``vert[s]`` and owns the
front edge ``vert[s] -> vert[next[s]]``, with the unmeshed region on its left. A binary heap orders
slots by the interior angle at their vertex. The slot with the smallest angle ``theta`` is
processed by the classic rules:

- ``theta < 75 deg``: close the corner with the triangle (prev, vertex, next);
- ``theta < 135 deg``: a new point on the bisector of the corner (two triangles follow);
- otherwise: a new point at the ideal apex of the shorter adjacent edge.

Fronts in fine parts of the size field go first (see ``_slot_key``), so they grade up before
coarse fronts arrive.

Before a new point is made, existing front vertices near it are tried as the apex, so fronts
merge instead of leaving slivers. When another front lies less than ``GAP_LAYERS`` rows ahead
(a ray from the edge along the new point's direction meets it), the new point goes to an even
fraction of that gap, so the rows left between two approaching fronts are spaced evenly instead
of the last one being squeezed (narrow channels, fronts colliding).

Fronts that descend from a curved boundary (a circle drawn as a polygon) and are a few rows in,
with no other front close ahead, put their new points on one equilateral lattice of the size
(see ``_snap``): following a circle inward, each row must shed about 5.4 nodes, which otherwise
leaves five- and seven-neighbour pairs all over a disc; on the lattice the interior is regular
and the irregular nodes stay in the first rows, as in Gmsh's Frontal-Delaunay meshes.

Every triangle is checked against the front: its corners must lie inside the front's wedges,
its new edges may not cross or touch a front edge, no front vertex may lie in it, and a new
point must keep its distance from the front. A uniform grid of front edges
makes each check local, so the cost is O(n) overall for bounded size gradation.

When no slot can advance under the normal rules, the rules are relaxed once; if the front is still
stuck the remaining cavities are filled by :func:`engine.cavity.fill_cavities` (constrained
Delaunay, no new points), and swapping and smoothing repair their quality.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, TypeVar, cast

import numba as nb
import numpy as np
from numpy.typing import NDArray

from .cavity import fill_cavities
from .discretize import Discretized
from .errors import Cancelled, LimitExceeded, MeshingError
from .mesh import Mesh
from .quality import shape_quality_xy
from .result import StopFn
from .sizing import SizeField, SizeTuple
from .sizing import size_field_at as _size

__all__ = ["advance_front"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

# Slot table columns (LAYER: how many triangles separate the slot's edge from the boundary;
# CURVED: 1 when the front descends from a curved stretch of boundary, see _curved_edges).
VERT, NEXT, PREV, VER, FAIL, ALIVE, LAYER, CURVED = 0, 1, 2, 3, 4, 5, 6, 7
N_COLS = 8
# Scalar state indices.
NP, NT, NS, NE, NH, LIVE, QUERY, RELAXED, RELAX_LEFT, OPS = range(10)
N_STATE = 16
# Kernel status codes.
DONE, BUDGET, STUCK, GROW = 0, 1, 2, 3

TWO_PI = 2.0 * math.pi
T_CLOSE = math.radians(75.0)
T_BISECT = math.radians(135.0)
T_CLOSE_RELAXED = math.radians(100.0)
#: Slots flatter than this are ordered by front layer, so all fronts advance evenly.
T_FLAT = math.radians(150.0)
MAX_TRIES = 3
#: Lattice snapping (see _snap): from row SNAP_LAYER in, a new point within SNAP_TOL of the size
#: of a lattice node moves there, unless another front is less than SNAP_CLEAR rows ahead (the
#: gap rule spaces those rows); a boundary edge whose both ends turn by CURVE_MIN..CURVE_MAX
#: degrees is curved.
SNAP_LAYER = 3
SNAP_TOL = 0.5
SNAP_CLEAR = 5.0
CURVE_MIN, CURVE_MAX = 0.5, 30.0
#: Slots where the size field is below FINE times its size away from features are processed
#: as if their angle were FINE_LEAD smaller (corners to close excepted); see _slot_key.
FINE = 0.8
FINE_LEAD = math.radians(90.0)
#: A new point keeps this fraction of its edge length away from front edges and vertices.
CLEAR_EDGE = 0.45
CLEAR_VERTEX = 0.55
#: Existing vertices within this fraction of the intended edge length from a new point's
#: position are tried as the apex instead.
MERGE_RADIUS = 0.7
Q_MIN = 0.4
#: Another front closer than this many rows ahead spaces the remaining rows evenly.
GAP_LAYERS = 3.0
GAP_MIN_ROWS = 2
Q_MIN_RELAXED = 0.02


@nb.njit(cache=True, inline="always")
def _orient(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@nb.njit(cache=True, inline="always")
def _ccw(ux: float, uy: float, vx: float, vy: float) -> float:
    """Angle from vector u counter-clockwise to vector v, in [0, 2 pi)."""
    a = math.atan2(ux * vy - uy * vx, ux * vx + uy * vy)
    if a < 0.0:
        a += TWO_PI
    return a


@nb.njit(cache=True, inline="always")
def _circumcircle(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float
) -> tuple[float, float, float]:
    d = 2.0 * _orient(ax, ay, bx, by, cx, cy)
    if d == 0.0:
        return 0.5 * (ax + bx), 0.5 * (ay + by), math.inf
    b2x, b2y, c2x, c2y = bx - ax, by - ay, cx - ax, cy - ay
    bb, cc = b2x * b2x + b2y * b2y, c2x * c2x + c2y * c2y
    ox = (c2y * bb - b2y * cc) / d
    oy = (b2x * cc - c2x * bb) / d
    return ax + ox, ay + oy, math.hypot(ox, oy)


@nb.njit(cache=True, inline="always")
def _seg_dist2(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    dx, dy = bx - ax, by - ay
    ll = dx * dx + dy * dy
    t = 0.0
    if ll > 0.0:
        t = min(max(((px - ax) * dx + (py - ay) * dy) / ll, 0.0), 1.0)
    qx, qy = ax + t * dx - px, ay + t * dy - py
    return qx * qx + qy * qy


@nb.njit(cache=True, inline="always")
def _segments_meet(
    p1x: float,
    p1y: float,
    p2x: float,
    p2y: float,
    q1x: float,
    q1y: float,
    q2x: float,
    q2y: float,
    tol: float,
) -> bool:
    """Whether two segments cross or come within ``tol`` of touching (conservative)."""
    lq = math.hypot(q2x - q1x, q2y - q1y)
    lp = math.hypot(p2x - p1x, p2y - p1y)
    d1 = _orient(q1x, q1y, q2x, q2y, p1x, p1y)
    d2 = _orient(q1x, q1y, q2x, q2y, p2x, p2y)
    if (d1 > tol * lq and d2 > tol * lq) or (d1 < -tol * lq and d2 < -tol * lq):
        return False
    d3 = _orient(p1x, p1y, p2x, p2y, q1x, q1y)
    d4 = _orient(p1x, p1y, p2x, p2y, q2x, q2y)
    if (d3 > tol * lp and d4 > tol * lp) or (d3 < -tol * lp and d4 < -tol * lp):
        return False
    # Straddling (or nearly collinear): they meet unless their boxes are apart.
    if min(p1x, p2x) > max(q1x, q2x) + tol or min(q1x, q2x) > max(p1x, p2x) + tol:
        return False
    return not (min(p1y, p2y) > max(q1y, q2y) + tol or min(q1y, q2y) > max(p1y, p2y) + tol)


# ----------------------------------------------------------------------------------------------
# Grid of front edges (lazy deletion: an entry is live while its slot is alive at that version).


@nb.njit(cache=True, inline="always")
def _cells(
    gp: FloatArray, nx: int, ny: int, x0: float, y0: float, x1: float, y1: float
) -> tuple[int, int, int, int]:
    """Grid cell index ranges (i0, i1, j0, j1), clamped to the grid, covering a box."""
    i0 = min(max(int((x0 - gp[0]) / gp[2]), 0), nx - 1)
    i1 = min(max(int((x1 - gp[0]) / gp[2]), 0), nx - 1)
    j0 = min(max(int((y0 - gp[1]) / gp[2]), 0), ny - 1)
    j1 = min(max(int((y1 - gp[1]) / gp[2]), 0), ny - 1)
    return i0, i1, j0, j1


@nb.njit(cache=True)
def _grid_insert(
    slots: IntArray, pts: FloatArray, ghead: IntArray, gent: IntArray, st: IntArray,
    gp: FloatArray, nx: int, ny: int, s: int,
) -> bool:  # fmt: skip
    a, b = slots[s, VERT], slots[slots[s, NEXT], VERT]
    x0, x1 = min(pts[a, 0], pts[b, 0]), max(pts[a, 0], pts[b, 0])
    y0, y1 = min(pts[a, 1], pts[b, 1]), max(pts[a, 1], pts[b, 1])
    i0, i1, j0, j1 = _cells(gp, nx, ny, x0, y0, x1, y1)
    need = (i1 - i0 + 1) * (j1 - j0 + 1)
    if st[NE] + need > gent.shape[0]:
        return False
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            c = j * nx + i
            e = st[NE]
            gent[e, 0] = s
            gent[e, 1] = slots[s, VER]
            gent[e, 2] = ghead[c]
            ghead[c] = e
            st[NE] += 1
    return True


@nb.njit(cache=True)
def _grid_rebuild(
    slots: IntArray, pts: FloatArray, ghead: IntArray, gent: IntArray, st: IntArray,
    gp: FloatArray, nx: int, ny: int,
) -> bool:  # fmt: skip
    ghead[:] = -1
    st[NE] = 0
    for s in range(st[NS]):
        if slots[s, ALIVE] == 1 and not _grid_insert(slots, pts, ghead, gent, st, gp, nx, ny, s):
            return False
    return True


# ----------------------------------------------------------------------------------------------
# Heap of (angle, slot, version), lazily invalidated.


@nb.njit(cache=True)
def _heap_push(
    hkey: FloatArray, href: IntArray, st: IntArray, key: float, s: int, ver: int
) -> bool:
    n = st[NH]
    if n >= hkey.shape[0]:
        return False
    hkey[n] = key
    href[n, 0] = s
    href[n, 1] = ver
    while n > 0:
        parent = (n - 1) >> 1
        if hkey[parent] <= hkey[n]:
            break
        hkey[parent], hkey[n] = hkey[n], hkey[parent]
        t0, t1 = href[parent, 0], href[parent, 1]
        href[parent, 0], href[parent, 1] = href[n, 0], href[n, 1]
        href[n, 0], href[n, 1] = t0, t1
        n = parent
    st[NH] += 1
    return True


@nb.njit(cache=True)
def _heap_pop(hkey: FloatArray, href: IntArray, st: IntArray) -> tuple[float, int, int]:
    key, s, ver = hkey[0], href[0, 0], href[0, 1]
    st[NH] -= 1
    n = st[NH]
    hkey[0] = hkey[n]
    href[0, 0], href[0, 1] = href[n, 0], href[n, 1]
    i = 0
    while True:
        left = 2 * i + 1
        if left >= n:
            break
        m = left
        if left + 1 < n and hkey[left + 1] < hkey[left]:
            m = left + 1
        if hkey[i] <= hkey[m]:
            break
        hkey[i], hkey[m] = hkey[m], hkey[i]
        t0, t1 = href[i, 0], href[i, 1]
        href[i, 0], href[i, 1] = href[m, 0], href[m, 1]
        href[m, 0], href[m, 1] = t0, t1
        i = m
    return key, s, ver


@nb.njit(cache=True)
def _slot_angle(slots: IntArray, pts: FloatArray, s: int) -> float:
    b = slots[s, VERT]
    a = slots[slots[s, PREV], VERT]
    c = slots[slots[s, NEXT], VERT]
    ang = _ccw(
        pts[c, 0] - pts[b, 0], pts[c, 1] - pts[b, 1], pts[a, 0] - pts[b, 0], pts[a, 1] - pts[b, 1]
    )
    return ang if ang > 0.0 else TWO_PI


@nb.njit(cache=True)
def _slot_key(slots: IntArray, pts: FloatArray, hv: FloatArray, gp: FloatArray, s: int) -> float:
    """Smallest angle first; slots flatter than ``T_FLAT`` tie, and ties go to the older front
    layer, then to the shorter edge (relative to the local size). Failed slots go last.

    A slot where the size field is below ``FINE`` times its size away from features
    (``gp[3]``), unless it is a corner to close, comes as if its angle were ``FINE_LEAD``
    smaller: fronts that must grade up from a fine boundary (a small hole's, a refined
    leading edge's) then advance before coarse fronts reach them. Coarse rows advance by their
    own small angles row after row, while a hole's front is all reflex angles; left to the
    angle order it was reached after a layer or two, and a coarse row met its fine edges with
    boundary nodes a triangle short (two of 93 degrees: no node move mends that)."""
    a, b = slots[s, VERT], slots[slots[s, NEXT], VERT]
    length = math.hypot(pts[b, 0] - pts[a, 0], pts[b, 1] - pts[a, 1]) / hv[a]
    key = _slot_angle(slots, pts, s)
    if key >= T_FLAT:
        key = T_FLAT + 1e-3 * slots[s, LAYER]
    if key >= T_CLOSE and hv[a] < FINE * gp[3]:
        key -= FINE_LEAD
    return key + 1e-7 * min(length, 10.0) + 1e6 * slots[s, FAIL]


# ----------------------------------------------------------------------------------------------
# Validity of a candidate triangle (u, v, w) on the front edge of slot e.


@nb.njit(cache=True)
def _wedge_ok(
    slots: IntArray, pts: FloatArray, e: int, k: int, w: int, wx: float, wy: float, tol: float
) -> bool:
    """Corners of the triangle at u, v (and at the apex slot k, if any) lie in the front wedges."""
    t = slots[e, NEXT]
    u, v = slots[e, VERT], slots[t, VERT]
    pu, nv = slots[slots[e, PREV], VERT], slots[slots[t, NEXT], VERT]
    ux, uy, vx, vy = pts[u, 0], pts[u, 1], pts[v, 0], pts[v, 1]
    if w != pu:
        wedge = _ccw(vx - ux, vy - uy, pts[pu, 0] - ux, pts[pu, 1] - uy)
        if wedge <= 0.0:
            wedge = TWO_PI
        phi = _ccw(vx - ux, vy - uy, wx - ux, wy - uy)
        if not (tol < phi < wedge - tol):
            return False
    if w != nv:
        wedge = _ccw(pts[nv, 0] - vx, pts[nv, 1] - vy, ux - vx, uy - vy)
        if wedge <= 0.0:
            wedge = TWO_PI
        phi = _ccw(pts[nv, 0] - vx, pts[nv, 1] - vy, wx - vx, wy - vy)
        if not (tol < phi < wedge - tol):
            return False
    if k >= 0:
        nw, pw = slots[slots[k, NEXT], VERT], slots[slots[k, PREV], VERT]
        bx, by = pts[nw, 0] - wx, pts[nw, 1] - wy
        wedge = _ccw(bx, by, pts[pw, 0] - wx, pts[pw, 1] - wy)
        if wedge <= 0.0:
            wedge = TWO_PI
        phi_u = 0.0 if u == nw else _ccw(bx, by, ux - wx, uy - wy)
        phi_v = wedge if v == pw else _ccw(bx, by, vx - wx, vy - wy)
        if u != nw and phi_u <= tol:
            return False
        if v != pw and phi_v >= wedge - tol:
            return False
        if phi_u >= phi_v:
            return False
    return True


@nb.njit(cache=True)
def _front_clear(
    slots: IntArray, pts: FloatArray, ghead: IntArray, gent: IntArray, st: IntArray,
    stamp: IntArray, gp: FloatArray, nx: int, ny: int, e: int, w: int, wx: float, wy: float,
    clear_edge: float, clear_vertex: float, tol: float,
) -> bool:  # fmt: skip
    """No front edge crosses the new edges and no front vertex lies in the triangle.

    With ``w < 0`` (a new point), front edges and vertices must also keep ``clear_edge`` /
    ``clear_vertex`` away from it.
    """
    t = slots[e, NEXT]
    u, v = slots[e, VERT], slots[t, VERT]
    pu, nv = slots[slots[e, PREV], VERT], slots[slots[t, NEXT], VERT]
    ux, uy, vx, vy = pts[u, 0], pts[u, 1], pts[v, 0], pts[v, 1]
    margin = max(clear_edge, clear_vertex) + tol
    x0 = min(ux, vx, wx) - margin
    x1 = max(ux, vx, wx) + margin
    y0 = min(uy, vy, wy) - margin
    y1 = max(uy, vy, wy) + margin
    i0, i1, j0, j1 = _cells(gp, nx, ny, x0, y0, x1, y1)
    st[QUERY] += 1
    q = st[QUERY]
    new_uw = w != pu  # edge u-w is new (not already the front edge w -> u)
    new_wv = w != nv
    ce2, cv2 = clear_edge * clear_edge, clear_vertex * clear_vertex
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            g = ghead[j * nx + i]
            while g >= 0:
                f = gent[g, 0]
                live = slots[f, ALIVE] == 1 and slots[f, VER] == gent[g, 1]
                g = gent[g, 2]
                if not live or stamp[f] == q:
                    continue
                stamp[f] = q
                if f == e:
                    continue
                a, b = slots[f, VERT], slots[slots[f, NEXT], VERT]
                ax, ay, bx, by = pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1]
                apart_u = a != u and b != u and a != w and b != w
                if new_uw and apart_u and _segments_meet(ux, uy, wx, wy, ax, ay, bx, by, tol):
                    return False
                apart_v = a != v and b != v and a != w and b != w
                if new_wv and apart_v and _segments_meet(wx, wy, vx, vy, ax, ay, bx, by, tol):
                    return False
                if a != u and a != v and a != w:
                    # A front vertex inside (or on) the triangle.
                    la = tol * math.hypot(vx - ux, vy - uy)
                    if (
                        _orient(ux, uy, vx, vy, ax, ay) > -la
                        and _orient(vx, vy, wx, wy, ax, ay) > -tol * math.hypot(wx - vx, wy - vy)
                        and _orient(wx, wy, ux, uy, ax, ay) > -tol * math.hypot(ux - wx, uy - wy)
                    ):
                        return False
                if w < 0:
                    if (ax - wx) ** 2 + (ay - wy) ** 2 < cv2:
                        return False
                    if _seg_dist2(wx, wy, ax, ay, bx, by) < ce2:
                        return False
    return True


@nb.njit(cache=True)
def _candidates_near(
    slots: IntArray, pts: FloatArray, ghead: IntArray, gent: IntArray, st: IntArray,
    stamp: IntArray, gp: FloatArray, nx: int, ny: int, px: float, py: float, r: float,
    out: IntArray,
) -> int:  # fmt: skip
    """Front slots whose vertex lies within ``r`` of (px, py); returns how many were written."""
    i0, i1, j0, j1 = _cells(gp, nx, ny, px - r, py - r, px + r, py + r)
    st[QUERY] += 1
    q = st[QUERY]
    n = 0
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            g = ghead[j * nx + i]
            while g >= 0:
                f = gent[g, 0]
                live = slots[f, ALIVE] == 1 and slots[f, VER] == gent[g, 1]
                g = gent[g, 2]
                if not live or stamp[f] == q:
                    continue
                stamp[f] = q
                a = slots[f, VERT]
                if (pts[a, 0] - px) ** 2 + (pts[a, 1] - py) ** 2 <= r * r and n < out.shape[0]:
                    out[n] = f
                    n += 1
    return n


# ----------------------------------------------------------------------------------------------
# Front updates.


@nb.njit(cache=True)
def _new_slot(slots: IntArray, st: IntArray, vert: int) -> int:
    s = st[NS]
    st[NS] += 1
    slots[s, VERT] = vert
    slots[s, VER] = 0
    slots[s, FAIL] = 0
    slots[s, ALIVE] = 1
    st[LIVE] += 1
    return s


@nb.njit(cache=True)
def _kill(slots: IntArray, st: IntArray, s: int) -> None:
    slots[s, ALIVE] = 0
    st[LIVE] -= 1


@nb.njit(cache=True)
def _remove_spike(slots: IntArray, st: IntArray, x: int) -> int:
    """Drop a spike ``p -> x -> p`` at slot ``x``; returns a surviving neighbour, or -1."""
    p1, p2 = slots[x, PREV], slots[x, NEXT]
    if slots[p1, VERT] != slots[p2, VERT]:
        return -2  # no spike here
    if p1 == p2:  # a loop of two slots: both go
        _kill(slots, st, x)
        _kill(slots, st, p1)
        return -1
    n2 = slots[p2, NEXT]
    slots[p1, NEXT] = n2
    slots[n2, PREV] = p1
    _kill(slots, st, x)
    _kill(slots, st, p2)
    return p1


@nb.njit(cache=True)
def _refresh(
    slots: IntArray, pts: FloatArray, hv: FloatArray, ghead: IntArray, gent: IntArray,
    hkey: FloatArray, href: IntArray, st: IntArray, gp: FloatArray, nx: int, ny: int, s: int,
) -> bool:  # fmt: skip
    """Re-index a slot whose edge or angle changed: new version, grid entry and heap entry."""
    if slots[s, ALIVE] != 1:
        return True
    slots[s, VER] += 1
    slots[s, FAIL] = 0
    if not _grid_insert(slots, pts, ghead, gent, st, gp, nx, ny, s):
        return False
    return _heap_push(hkey, href, st, _slot_key(slots, pts, hv, gp, s), s, slots[s, VER])


@nb.njit(cache=True)
def _apply(
    slots: IntArray, pts: FloatArray, hv: FloatArray, tris: IntArray, ghead: IntArray,
    gent: IntArray, hkey: FloatArray, href: IntArray, st: IntArray, gp: FloatArray, nx: int,
    ny: int, e: int, k: int, w: int,
) -> bool:  # fmt: skip
    """Add triangle (u, v, w) on the edge of slot ``e``; ``k`` is w's slot (-1 for a new point)."""
    t = slots[e, NEXT]
    u, v = slots[e, VERT], slots[t, VERT]
    n = st[NT]
    tris[n, 0], tris[n, 1], tris[n, 2] = u, v, w
    st[NT] += 1
    layer = slots[e, LAYER] + 1
    curved = slots[e, CURVED]
    touched = np.empty(8, dtype=np.int64)
    nt = 0
    if k < 0:
        q = _new_slot(slots, st, w)
        slots[q, LAYER] = layer
        slots[q, CURVED] = curved
        slots[e, LAYER] = layer
        slots[e, NEXT] = q
        slots[q, PREV] = e
        slots[q, NEXT] = t
        slots[t, PREV] = q
        touched[0], touched[1], touched[2] = e, q, t
        nt = 3
    else:
        pk = slots[k, PREV]
        k2 = _new_slot(slots, st, w)
        slots[k2, LAYER] = layer
        slots[k2, CURVED] = curved
        slots[e, LAYER] = layer
        slots[e, NEXT] = k
        slots[k, PREV] = e
        slots[k2, PREV] = pk
        slots[pk, NEXT] = k2
        slots[k2, NEXT] = t
        slots[t, PREV] = k2
        touched[0], touched[1], touched[2], touched[3] = e, k, k2, t
        nt = 4
    # Cancel spikes (u -> w -> u and the like) left by closing against adjacent edges.
    changed = True
    while changed:
        changed = False
        for i in range(nt):
            x = touched[i]
            if slots[x, ALIVE] != 1:
                continue
            r = _remove_spike(slots, st, x)
            if r != -2:
                changed = True
                if r >= 0 and nt < 8:
                    touched[nt] = r
                    nt += 1
    # A slot's angle depends on its previous, own and next vertex: exactly the touched slots
    # changed one of those (a spike's surviving neighbour changed its next vertex).
    for i in range(nt):
        if not _refresh(slots, pts, hv, ghead, gent, hkey, href, st, gp, nx, ny, touched[i]):
            return False
    return True


# ----------------------------------------------------------------------------------------------
# Choosing the triangle for a slot.


@nb.njit(cache=True)
def _try_apex(
    slots: IntArray, pts: FloatArray, hv: FloatArray, tris: IntArray, ghead: IntArray,
    gent: IntArray, hkey: FloatArray, href: IntArray, st: IntArray, stamp: IntArray,
    gp: FloatArray, nx: int, ny: int, sf: SizeTuple, cand: IntArray,
    e: int, px: float, py: float, d: float, q_min: float, allow_new: bool,
) -> int:  # fmt: skip
    """Triangle on the edge of slot ``e`` with the best apex near (px, py), new or existing.

    Returns 1 when a triangle was added, 0 when no candidate is valid, -1 when out of room.
    """
    t = slots[e, NEXT]
    u, v = slots[e, VERT], slots[t, VERT]
    ux, uy, vx, vy = pts[u, 0], pts[u, 1], pts[v, 0], pts[v, 1]
    tol = 1e-7 * d
    atol = 1e-9
    # Candidates: front vertices in the circumcircle of (u, v, P) or near P.
    ccx, ccy, rad = _circumcircle(ux, uy, vx, vy, px, py)
    reach = max(1.05 * rad, math.hypot(ccx - px, ccy - py) + MERGE_RADIUS * d)
    n = _candidates_near(slots, pts, ghead, gent, st, stamp, gp, nx, ny, ccx, ccy, reach, cand)
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
        ang = _ccw(ux - wx, uy - wy, vx - wx, vy - wy)
        if ang >= math.pi or ang <= best_a:
            continue
        if shape_quality_xy(ux, uy, vx, vy, wx, wy) < q_min:
            continue
        if not _wedge_ok(slots, pts, e, k, w, wx, wy, atol):
            continue
        if not _front_clear(
            slots, pts, ghead, gent, st, stamp, gp, nx, ny, e, w, wx, wy, 0.0, 0.0, tol
        ):
            continue
        best_k, best_a = k, ang
    new_ok = False
    if allow_new:
        # A new point only when no existing vertex lies in its circumcircle.
        ang_new = _ccw(ux - px, uy - py, vx - px, vy - py)
        if shape_quality_xy(ux, uy, vx, vy, px, py) >= q_min and best_a < ang_new:
            new_ok = _wedge_ok(slots, pts, e, -1, -1, px, py, atol) and _front_clear(
                slots, pts, ghead, gent, st, stamp, gp, nx, ny, e, -1, px, py,
                CLEAR_EDGE * d, CLEAR_VERTEX * d, tol,
            )  # fmt: skip
    if new_ok:
        w = st[NP]
        pts[w, 0], pts[w, 1] = px, py
        hv[w] = _size(sf, px, py)
        st[NP] += 1
        ok = _apply(slots, pts, hv, tris, ghead, gent, hkey, href, st, gp, nx, ny, e, -1, w)
        return 1 if ok else -1
    if best_k >= 0:
        w = slots[best_k, VERT]
        ok = _apply(slots, pts, hv, tris, ghead, gent, hkey, href, st, gp, nx, ny, e, best_k, w)
        return 1 if ok else -1
    return 0


@nb.njit(cache=True)
def _gap_ahead(
    slots: IntArray, pts: FloatArray, ghead: IntArray, gent: IntArray, st: IntArray,
    stamp: IntArray, gp: FloatArray, nx: int, ny: int, e: int, e2: int, mx: float, my: float,
    dx: float, dy: float, reach: float,
) -> float:  # fmt: skip
    """Distance from (mx, my) along the unit direction (dx, dy) to the first front edge other
    than those of slots ``e`` and ``e2``, or ``reach`` when none is that close."""
    ex, ey = mx + dx * reach, my + dy * reach
    i0, i1, j0, j1 = _cells(gp, nx, ny, min(mx, ex), min(my, ey), max(mx, ex), max(my, ey))
    st[QUERY] += 1
    q = st[QUERY]
    best = reach
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            g = ghead[j * nx + i]
            while g >= 0:
                f = gent[g, 0]
                live = slots[f, ALIVE] == 1 and slots[f, VER] == gent[g, 1]
                g = gent[g, 2]
                if not live or stamp[f] == q:
                    continue
                stamp[f] = q
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


@nb.njit(cache=True)
def _snap(sf: SizeTuple, slots: IntArray, e: int, px: float, py: float) -> tuple[float, float]:
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
    if slots[e, CURVED] == 0 or slots[e, LAYER] < SNAP_LAYER:
        return px, py
    h = sf[0]
    if _size(sf, px, py) < h * (1.0 - 1e-9):
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
def _place(
    slots: IntArray, pts: FloatArray, ghead: IntArray, gent: IntArray, st: IntArray,
    stamp: IntArray, gp: FloatArray, nx: int, ny: int, sf: SizeTuple, e: int, e2: int,
    s: int, ox: float, oy: float, dx: float, dy: float, step: float, scale: float,
) -> tuple[float, float, float]:  # fmt: skip
    """The new point ``step`` from (ox, oy) along the unit direction (dx, dy), for slot ``s``,
    and the step taken.

    When another front (not slot ``e``'s or ``e2``'s edge) lies less than ``GAP_LAYERS`` rows
    ahead, the rows left are spaced evenly: the step becomes ``gap / round(gap / step)``. The
    step is then multiplied by ``scale``; with no front within ``SNAP_CLEAR`` steps, the point
    may move onto the lattice (:func:`_snap`).
    """
    reach = max(GAP_LAYERS, SNAP_CLEAR) * step
    gap = _gap_ahead(slots, pts, ghead, gent, st, stamp, gp, nx, ny, e, e2, ox, oy, dx, dy, reach)
    rows = math.floor(gap / step + 0.5)
    if gap < GAP_LAYERS * step and rows >= GAP_MIN_ROWS:
        step = gap / rows
    step *= scale
    px, py = ox + dx * step, oy + dy * step
    if gap >= SNAP_CLEAR * step:
        px, py = _snap(sf, slots, s, px, py)
    return px, py, step


@nb.njit(cache=True)
def _ideal_apex(
    slots: IntArray, pts: FloatArray, hv: FloatArray, ghead: IntArray, gent: IntArray,
    st: IntArray, stamp: IntArray, gp: FloatArray, nx: int, ny: int, sf: SizeTuple, e: int,
    scale: float,
) -> tuple[float, float, float]:  # fmt: skip
    """Apex of a near-equilateral triangle on the edge of slot ``e`` for the local size.

    When another front lies ahead closer than ``GAP_LAYERS`` rows, the rows left between them
    are spaced evenly: the apex goes to ``gap / round(gap / height)``, so two fronts meeting
    across a gap that is not a whole number of rows close with evenly stretched triangles
    instead of a last row of slivers.
    """
    u, v = slots[e, VERT], slots[slots[e, NEXT], VERT]
    ux, uy, vx, vy = pts[u, 0], pts[u, 1], pts[v, 0], pts[v, 1]
    length = math.hypot(vx - ux, vy - uy)
    nx_, ny_ = -(vy - uy) / length, (vx - ux) / length
    mx, my = 0.5 * (ux + vx), 0.5 * (uy + vy)
    h = 0.5 * (hv[u] + hv[v])
    h_far = _size(sf, mx + nx_ * 0.866 * h, my + ny_ * 0.866 * h)
    delta = min(max(0.5 * (h + h_far), 0.55 * length), 1.6 * length)
    height = math.sqrt(max(delta * delta - 0.25 * length * length, 0.09 * length * length))
    px, py, _ = _place(
        slots, pts, ghead, gent, st, stamp, gp, nx, ny, sf, e, e, e, mx, my, nx_, ny_, height, scale
    )
    return px, py, delta


@nb.njit(cache=True)
def _process(
    slots: IntArray, pts: FloatArray, hv: FloatArray, tris: IntArray, ghead: IntArray,
    gent: IntArray, hkey: FloatArray, href: IntArray, st: IntArray, stamp: IntArray,
    gp: FloatArray, nx: int, ny: int, sf: SizeTuple, cand: IntArray, s: int,
) -> int:  # fmt: skip
    """Advance the front at slot ``s`` (the smallest angle); 1 done, 0 no move, -1 no room."""
    ps, ns = slots[s, PREV], slots[s, NEXT]
    a, b, c = slots[ps, VERT], slots[s, VERT], slots[ns, VERT]
    ax, ay, bx, by, cx, cy = pts[a, 0], pts[a, 1], pts[b, 0], pts[b, 1], pts[c, 0], pts[c, 1]
    la = math.hypot(ax - bx, ay - by)
    lc = math.hypot(cx - bx, cy - by)
    theta = _slot_angle(slots, pts, s)
    relaxed = st[RELAXED] > 0
    q_min = Q_MIN_RELAXED if relaxed else Q_MIN
    close_limit = T_CLOSE_RELAXED if relaxed else T_CLOSE
    args = (slots, pts, hv, tris, ghead, gent, hkey, href, st, stamp, gp, nx, ny, sf, cand)
    if theta < close_limit:
        r = _try_apex(*args, ps, cx, cy, max(la, lc), q_min, False)
        if r != 0:
            return r
    if theta < T_BISECT:
        # A new point on the bisector splits the corner into two triangles.
        half = 0.5 * theta
        dx, dy = (cx - bx) / lc, (cy - by) / lc
        bis_x = dx * math.cos(half) - dy * math.sin(half)
        bis_y = dx * math.sin(half) + dy * math.cos(half)
        h0 = hv[b]
        d = 0.5 * (h0 + _size(sf, bx + bis_x * h0, by + bis_y * h0))
        lavg = 0.5 * (la + lc)
        d = min(max(d, 0.7 * lavg), 1.4 * lavg)
        qx, qy, d = _place(
            slots, pts, ghead, gent, st, stamp, gp, nx, ny, sf, ps, s, s, bx, by, bis_x, bis_y, d,
            1.0,
        )  # fmt: skip
        r = _try_apex(*args, ps, qx, qy, d, q_min, True)
        if r != 0:
            return r
        if close_limit <= theta < T_CLOSE_RELAXED:
            r = _try_apex(*args, ps, cx, cy, max(la, lc), q_min, False)
            if r != 0:
                return r
    scales = (1.0, 0.6, 0.35) if relaxed else (1.0, 1.0, 1.0)
    for i in range(3 if relaxed else 1):
        for attempt in range(2):
            e = s if (lc <= la) == (attempt == 0) else ps
            px, py, d = _ideal_apex(
                slots, pts, hv, ghead, gent, st, stamp, gp, nx, ny, sf, e, scales[i]
            )
            r = _try_apex(*args, e, px, py, d, q_min, True)
            if r != 0:
                return r
    return 0


@nb.njit(cache=True)
def _heap_rebuild(
    slots: IntArray, pts: FloatArray, hv: FloatArray, hkey: FloatArray, href: IntArray,
    st: IntArray, gp: FloatArray,
) -> bool:  # fmt: skip
    st[NH] = 0
    for s in range(st[NS]):
        waiting = slots[s, ALIVE] == 1 and slots[s, FAIL] < MAX_TRIES
        if waiting and not _heap_push(
            hkey, href, st, _slot_key(slots, pts, hv, gp, s), s, slots[s, VER]
        ):
            return False
    return True


@nb.njit(cache=True)
def _run(
    slots: IntArray, pts: FloatArray, hv: FloatArray, tris: IntArray, ghead: IntArray,
    gent: IntArray, hkey: FloatArray, href: IntArray, st: IntArray, stamp: IntArray,
    gp: FloatArray, nx: int, ny: int, sf: SizeTuple, budget: int,
) -> int:  # fmt: skip
    """Advance the front by up to ``budget`` triangles; returns a status code."""
    cand = np.empty(256, dtype=np.int64)
    done = 0
    while done < budget:
        if st[LIVE] == 0:
            return DONE
        if st[NP] + 2 > pts.shape[0] or st[NT] + 2 > tris.shape[0] or st[NS] + 4 > slots.shape[0]:
            return GROW
        if stamp.shape[0] < slots.shape[0]:
            return GROW
        if st[NH] + 64 > hkey.shape[0] and (
            not _heap_rebuild(slots, pts, hv, hkey, href, st, gp) or st[NH] + 64 > hkey.shape[0]
        ):
            return GROW
        if st[NE] + 4096 > gent.shape[0]:
            if not _grid_rebuild(slots, pts, ghead, gent, st, gp, nx, ny):
                return GROW
            if st[NE] + 4096 > gent.shape[0]:
                return GROW
        if st[NH] == 0:
            if st[RELAXED] > 0:
                return STUCK
            # Nothing can advance under the normal rules: relax them for a while.
            st[RELAXED] = 1
            st[RELAX_LEFT] = st[LIVE] + 16
            for s in range(st[NS]):
                slots[s, FAIL] = 0
            _heap_rebuild(slots, pts, hv, hkey, href, st, gp)
            continue
        _, s, ver = _heap_pop(hkey, href, st)
        if slots[s, ALIVE] != 1 or slots[s, VER] != ver:
            continue
        r = _process(
            slots, pts, hv, tris, ghead, gent, hkey, href, st, stamp, gp, nx, ny, sf, cand, s
        )
        if r < 0:
            return -1
        if r == 1:
            done += 1
            st[OPS] += 1
            if st[RELAXED] > 0:
                st[RELAX_LEFT] -= 1
                if st[RELAX_LEFT] <= 0:
                    st[RELAXED] = 0
        else:
            slots[s, FAIL] += 1
            if slots[s, FAIL] < MAX_TRIES:
                _heap_push(hkey, href, st, _slot_key(slots, pts, hv, gp, s), s, slots[s, VER])
    return BUDGET


@nb.njit(cache=True)
def _init(
    slots: IntArray, pts: FloatArray, hv: FloatArray, ghead: IntArray, gent: IntArray,
    hkey: FloatArray, href: IntArray, st: IntArray, gp: FloatArray, nx: int, ny: int,
) -> bool:  # fmt: skip
    for s in range(st[NS]):
        if not _grid_insert(slots, pts, ghead, gent, st, gp, nx, ny, s):
            return False
    return _heap_rebuild(slots, pts, hv, hkey, href, st, gp)


# ----------------------------------------------------------------------------------------------
# Driver.


_A = TypeVar("_A", bound=NDArray[Any])


def _bigger(arr: _A, used: int, need: int) -> _A:
    if used + need <= len(arr):
        return arr
    new = np.empty((max(2 * len(arr), used + need), *arr.shape[1:]), dtype=arr.dtype)
    new[:used] = arr[:used]
    return cast(_A, new)


@dataclass
class _State:
    """Growable arrays of the front kernel (all state lives here between kernel calls)."""

    pts: FloatArray
    hv: FloatArray
    tris: IntArray
    slots: IntArray
    stamp: IntArray
    ghead: IntArray
    gent: IntArray
    hkey: FloatArray
    href: IntArray
    st: IntArray

    def grow(self, budget: int) -> None:
        """Make room for ``budget`` more triangles (doubling what is short)."""
        st = self.st
        bigger = _bigger
        self.pts = bigger(self.pts, int(st[NP]), budget + 8)
        self.hv = bigger(self.hv, int(st[NP]), budget + 8)
        self.tris = bigger(self.tris, int(st[NT]), budget + 8)
        self.slots = bigger(self.slots, int(st[NS]), 2 * budget + 8)
        if len(self.stamp) < len(self.slots):
            stamp = np.zeros(len(self.slots), dtype=np.int64)
            stamp[: len(self.stamp)] = self.stamp
            self.stamp = stamp
        self.hkey = bigger(self.hkey, int(st[NH]), 10 * budget + 1024)
        self.href = bigger(self.href, int(st[NH]), 10 * budget + 1024)
        self.gent = bigger(self.gent, int(st[NE]), 40 * budget + 8192)


def _grid_params(points: FloatArray, field: SizeField) -> tuple[FloatArray, int, int]:
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-300))
    cell = max(field.size, span / 2048.0)
    pad = 0.5 * cell
    nx = math.ceil((hi[0] - lo[0] + 2 * pad) / cell) + 1
    ny = math.ceil((hi[1] - lo[1] + 2 * pad) / cell) + 1
    # gp[3]: the field's size away from features, against which fine fronts are told apart.
    return np.array([lo[0] - pad, lo[1] - pad, cell, field.size]), nx, ny


def _curved_edges(points: FloatArray, edges: IntArray) -> IntArray:
    """1 for boundary edges whose both ends turn by CURVE_MIN..CURVE_MAX degrees (a curve drawn
    as a polygon), 0 for straight stretches and corners."""
    n = len(points)
    nxt = np.full(n, -1, dtype=np.int64)
    nxt[edges[:, 0]] = edges[:, 1]
    prv = np.full(n, -1, dtype=np.int64)
    prv[edges[:, 1]] = edges[:, 0]
    d_in = points - points[prv]
    d_out = points[nxt] - points
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    turn = np.abs(np.degrees(np.arctan2(cross, (d_in * d_out).sum(axis=1))))
    smooth = (turn > CURVE_MIN) & (turn < CURVE_MAX)
    return (smooth[edges[:, 0]] & smooth[edges[:, 1]]).astype(np.int64)


def _region_area(points: FloatArray, edges: IntArray) -> float:
    a, b = points[edges[:, 0]], points[edges[:, 1]]
    return 0.5 * float(np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]))


def advance_front(
    boundary: Discretized,
    field: SizeField,
    should_stop: StopFn | None = None,
    budget: int = 50_000,
    max_triangles: int = 5_000_000,
) -> Mesh:
    """Triangulate the region bounded by ``boundary`` following ``field``.

    >>> from engine.boundary import make_region
    >>> from engine.discretize import discretize
    >>> from engine.params import SizingParams
    >>> from engine.sizing import build_size_field
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> field = build_size_field(square, SizingParams(size=0.2))
    >>> mesh = advance_front(discretize(square, field), field)
    >>> bool(abs(mesh.areas.sum() - 1.0) < 1e-12), bool(mesh.areas.min() > 0)
    (True, True)
    """
    points, edges = boundary.points, boundary.edges
    n0 = len(points)
    est = int(max(_region_area(points, edges), 0.0) / (0.433 * field.size**2) * 1.2) + 2 * n0 + 64
    est = min(est, 4 * budget + 2 * n0 + 64)
    pts = np.empty((est // 2 + n0 + 16, 2))
    pts[:n0] = points
    hv = np.empty(len(pts))
    hv[:n0] = boundary.sizes
    slots = np.zeros((2 * len(pts), N_COLS), dtype=np.int64)
    start_of = np.full(n0, -1, dtype=np.int64)
    start_of[edges[:, 0]] = np.arange(len(edges))
    nxt = start_of[edges[:, 1]]
    slots[: len(edges), VERT] = edges[:, 0]
    slots[: len(edges), NEXT] = nxt
    slots[nxt, PREV] = np.arange(len(edges))
    slots[: len(edges), ALIVE] = 1
    slots[: len(edges), CURVED] = _curved_edges(points, edges)
    gp, gnx, gny = _grid_params(points, field)
    st = np.zeros(N_STATE, dtype=np.int64)
    st[NP], st[NS], st[LIVE] = n0, len(edges), len(edges)
    state = _State(
        pts=pts,
        hv=hv,
        tris=np.empty((est, 3), dtype=np.int64),
        slots=slots,
        stamp=np.zeros(len(slots), dtype=np.int64),
        ghead=np.full(gnx * gny, -1, dtype=np.int64),
        gent=np.empty((16 * len(edges) + 8192, 3), dtype=np.int64),
        hkey=np.empty(4 * len(edges) + 1024),
        href=np.empty((4 * len(edges) + 1024, 2), dtype=np.int64),
        st=st,
    )
    if not _init(
        state.slots, state.pts, state.hv, state.ghead, state.gent, state.hkey, state.href,
        st, gp, gnx, gny,
    ):  # fmt: skip
        raise MeshingError("front initialisation ran out of room")
    sf = field.as_tuple()
    # Chunks no larger than the mesh, so small jobs do not allocate for large ones.
    budget = max(min(budget, 2 * est), 256)
    while True:
        state.grow(budget)
        status = _run(
            state.slots, state.pts, state.hv, state.tris, state.ghead, state.gent, state.hkey,
            state.href, st, state.stamp, gp, gnx, gny, sf, budget,
        )  # fmt: skip
        if status in (DONE, STUCK):
            break
        if status < 0:
            raise MeshingError("the advancing front ran out of room mid-update")
        if should_stop is not None and should_stop():
            raise Cancelled("stopped while meshing")
        if st[NT] > max_triangles:
            raise LimitExceeded(
                f"meshing passed the limit of {max_triangles} triangles",
                limit=max_triangles,
                estimate=int(st[NT]),
            )
    np_, nt = int(st[NP]), int(st[NT])
    pts_out = state.pts[:np_].copy()
    tris_out = state.tris[:nt].copy()
    if status == STUCK:
        alive = np.flatnonzero(state.slots[: st[NS], ALIVE] == 1)
        rest = np.stack(
            [state.slots[alive, VERT], state.slots[state.slots[alive, NEXT], VERT]], axis=1
        )
        tris_out = np.concatenate([tris_out, fill_cavities(pts_out, rest)])
    return Mesh(pts_out, tris_out)
