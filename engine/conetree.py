"""A bounding-volume tree over cone features, so the size field costs O(log n) per point.

Every feature is a segment ``a -> b`` whose size grows linearly from ``ha`` at ``a`` to ``hb`` at
``b`` (a point feature has ``a == b``). The field is the lower envelope of the cones
``h(q) + slope_f * |x - q|`` over every point ``q`` of every feature ``f`` (each feature grows
at its own rate ``slope_f``, by default the field's ``slope``), clamped to ``size``. A query
walks the tree nearest box first and skips a box whose lower bound (its smallest size plus
its smallest slope times the distance to it) cannot beat the best value found by more than the
relative tolerance ``TOLERANCE``, so a dense line of equal features (a long thin gap) costs a few
boxes, not one evaluation per feature.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "LEAF", "TOLERANCE", "ConeTree", "build_boxes", "build_tree", "cone_min", "slots_meeting",
]  # fmt: skip

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Features per leaf box.
LEAF = 8
#: A box is skipped when it cannot lower the field by more than this fraction: the field is
#: within ``[exact, (1 + TOLERANCE) * exact]``, and exact at the features themselves.
TOLERANCE = 0.01
_STACK = 128


class ConeTree(NamedTuple):
    """The size field as numba kernels take it (see :func:`cone_min`)."""

    size: float  #: size away from features
    slope: float  #: growth - 1
    size_min: float  #: lower clamp (0 when none)
    fa: FloatArray  #: (f, 2) feature starts, in tree order
    fb: FloatArray  #: (f, 2) feature ends
    ox: float  #: lower-left corner of the region's bounding box (the front's lattice origin;
    oy: float  #: the front reads these two by position, 5 and 6, as in the former tuple)
    ha: FloatArray  #: (f,) size asked at each start
    hb: FloatArray  #: (f,) size asked at each end
    box: FloatArray  #: (m, 4) node boxes x0, y0, x1, y1
    hmin: FloatArray  #: (m,) smallest size asked inside each node
    child: IntArray  #: (m, 2) children of each node, -1 for a leaf
    span: IntArray  #: (m, 2) range of features of each node
    fslope: FloatArray  #: (f,) growth - 1 of each feature
    smin: FloatArray  #: (m,) smallest slope of the features inside each node


@nb.njit(cache=True, inline="always")
def _cone(x: float, y: float, t: ConeTree, f: int) -> float:  # pragma: no cover - compiled
    """Smallest ``h(q) + slope_f |x - q|`` over the points ``q`` of feature ``f`` (closed form:
    the function is convex along the segment)."""
    ax, ay = t.fa[f, 0], t.fa[f, 1]
    dx, dy = t.fb[f, 0] - ax, t.fb[f, 1] - ay
    length = math.sqrt(dx * dx + dy * dy)
    h0 = t.ha[f]
    slope = t.fslope[f]
    if length == 0.0:
        return h0 + slope * math.sqrt((x - ax) ** 2 + (y - ay) ** 2)
    u = ((x - ax) * dx + (y - ay) * dy) / length
    v = abs((y - ay) * dx - (x - ax) * dy) / length
    k = (t.hb[f] - h0) / length
    if abs(k) < slope:
        s = min(max(u - k * v / math.sqrt(slope * slope - k * k), 0.0), length)
    else:
        s = 0.0 if k > 0.0 else length
    return h0 + k * s + slope * math.sqrt((s - u) ** 2 + v * v)


@nb.njit(cache=True, inline="always")
def _bound(x: float, y: float, t: ConeTree, node: int) -> float:  # pragma: no cover - compiled
    dx = max(t.box[node, 0] - x, 0.0, x - t.box[node, 2])
    dy = max(t.box[node, 1] - y, 0.0, y - t.box[node, 3])
    return t.hmin[node] + t.smin[node] * math.sqrt(dx * dx + dy * dy)


@nb.njit(cache=True)
def cone_min(t: ConeTree, x: float, y: float) -> tuple[float, int]:  # pragma: no cover - compiled
    """The size field at ``(x, y)`` and the number of feature evaluations it took."""
    best = t.size
    work = 0
    if t.hmin.shape[0] == 0:
        return max(best, t.size_min), work
    # Each entry keeps the bound it was pushed with: popping it need not compute it again.
    stack = np.empty(_STACK, dtype=np.int64)
    bounds = np.empty(_STACK)
    stack[0], bounds[0] = 0, _bound(x, y, t, 0)
    top = 1
    shrink = 1.0 + TOLERANCE
    while top > 0:
        top -= 1
        node = stack[top]
        if bounds[top] * shrink >= best:
            continue
        c0, c1 = t.child[node, 0], t.child[node, 1]
        if c0 < 0:
            for f in range(t.span[node, 0], t.span[node, 1]):
                work += 1
                v = _cone(x, y, t, f)
                if v < best:
                    best = v
            continue
        # Push the farther child first so the nearer one is searched first.
        b0, b1 = _bound(x, y, t, c0), _bound(x, y, t, c1)
        if b0 <= b1:
            stack[top], stack[top + 1] = c1, c0
            bounds[top], bounds[top + 1] = b1, b0
        else:
            stack[top], stack[top + 1] = c0, c1
            bounds[top], bounds[top + 1] = b0, b1
        top += 2
    return max(best, t.size_min), work


@nb.njit(cache=True)
def _build(
    fa: FloatArray, fb: FloatArray, ha: FloatArray, hb: FloatArray, sl: FloatArray
) -> tuple[IntArray, FloatArray, FloatArray, IntArray, IntArray, FloatArray]:  # pragma: no cover
    """Median-split tree over feature midpoints; returns the feature order and the nodes."""
    n = fa.shape[0]
    order = np.arange(n)
    mid = 0.5 * (fa + fb)
    cap = 2 * (n // (LEAF // 2) + 1) + 1
    box = np.empty((cap, 4))
    hmin = np.empty(cap)
    smin = np.empty(cap)
    child = np.full((cap, 2), -1, dtype=np.int64)
    span = np.empty((cap, 2), dtype=np.int64)
    todo = np.empty((cap, 3), dtype=np.int64)  # node, lo, hi
    todo[0] = (0, 0, n)
    ntodo, nodes = 1, 1
    while ntodo > 0:
        ntodo -= 1
        node, lo, hi = todo[ntodo, 0], todo[ntodo, 1], todo[ntodo, 2]
        span[node] = (lo, hi)
        x0 = y0 = np.inf
        x1 = y1 = -np.inf
        h = sm = np.inf
        for i in range(lo, hi):
            f = order[i]
            x0 = min(x0, fa[f, 0], fb[f, 0])
            y0 = min(y0, fa[f, 1], fb[f, 1])
            x1 = max(x1, fa[f, 0], fb[f, 0])
            y1 = max(y1, fa[f, 1], fb[f, 1])
            h = min(h, ha[f], hb[f])
            sm = min(sm, sl[f])
        box[node] = (x0, y0, x1, y1)
        hmin[node] = h
        smin[node] = sm
        if hi - lo <= LEAF:
            continue
        axis = 0 if x1 - x0 >= y1 - y0 else 1
        part = order[lo:hi]
        order[lo:hi] = part[np.argsort(mid[part, axis], kind="mergesort")]
        m = (lo + hi) // 2
        child[node] = (nodes, nodes + 1)
        todo[ntodo] = (nodes, lo, m)
        todo[ntodo + 1] = (nodes + 1, m, hi)
        ntodo += 2
        nodes += 2
    return order, box[:nodes], hmin[:nodes], child[:nodes], span[:nodes], smin[:nodes]


def build_tree(
    size: float,
    slope: float,
    size_min: float,
    origin: tuple[float, float],
    fa: FloatArray,
    fb: FloatArray,
    ha: FloatArray,
    hb: FloatArray,
    slopes: FloatArray | None = None,
) -> ConeTree:
    """The tree over features ``fa -> fb`` asking ``ha -> hb``, each growing away at its
    ``slopes`` entry (default ``slope``).

    >>> t = build_tree(1.0, 0.2, 0.0, (0.0, 0.0), np.zeros((1, 2)), np.array([[1.0, 0.0]]),
    ...                np.array([0.1]), np.array([0.1]))
    >>> round(cone_min(t, 0.5, 1.0)[0], 6)
    0.3
    """
    if len(ha) == 0:
        empty = np.empty((0, 2))
        return ConeTree(
            size, slope, size_min, empty, empty, *origin, np.empty(0), np.empty(0),
            np.empty((0, 4)), np.empty(0), np.empty((0, 2), dtype=np.int64),
            np.empty((0, 2), dtype=np.int64), np.empty(0), np.empty(0),
        )  # fmt: skip
    fa, fb = np.ascontiguousarray(fa, np.float64), np.ascontiguousarray(fb, np.float64)
    ha, hb = np.ascontiguousarray(ha, np.float64), np.ascontiguousarray(hb, np.float64)
    sl = np.full(len(ha), slope) if slopes is None else np.ascontiguousarray(slopes, np.float64)
    order, box, hmin, child, span, smin = _build(fa, fb, ha, hb, sl)
    return ConeTree(
        size, slope, size_min, fa[order], fb[order], *origin, ha[order], hb[order], box, hmin,
        child, span, sl[order], smin,
    )  # fmt: skip


def build_boxes(a: FloatArray, b: FloatArray) -> tuple[IntArray, FloatArray, IntArray, IntArray]:
    """The same median-split tree over plain segments ``a -> b``: the segment in each slot,
    and the nodes' boxes, children and slot ranges (the gap search walks it)."""
    zero = np.zeros(len(a))
    order, box, _, child, span, _ = _build(a, b, zero, zero, zero)
    return order, box, child, span


@nb.njit(cache=True)
def slots_meeting(
    box: FloatArray,
    child: IntArray,
    span: IntArray,
    query: tuple[float, float, float, float],
    stack: IntArray,
    out: IntArray,
) -> int:  # pragma: no cover - compiled
    """Writes to ``out`` the slots of the leaves of a :func:`build_boxes` tree whose boxes meet
    the box ``query`` (x0, y0, x1, y1; infinite sides allowed) and returns how many; ``stack``
    (128 entries) and ``out`` (one entry per slot) are the caller's scratch."""
    q0, q1, q2, q3 = query
    n = 0
    stack[0] = 0
    top = 1
    while top > 0:
        top -= 1
        node = stack[top]
        if box[node, 0] > q2 or box[node, 2] < q0 or box[node, 1] > q3 or box[node, 3] < q1:
            continue
        if child[node, 0] >= 0:
            stack[top], stack[top + 1] = child[node, 0], child[node, 1]
            top += 2
            continue
        for slot in range(span[node, 0], span[node, 1]):
            out[n] = slot
            n += 1
    return n
