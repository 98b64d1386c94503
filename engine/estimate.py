"""Triangle-count estimate: how many triangles the mesh of a region will have, before meshing.

The area term integrates ``1 / (EQUILATERAL_AREA h^2)`` on an adaptive quadtree; the boundary
term counts the nodes the discretisation will put on the rings. Admission compares the estimate
with the configured limits, so it must be fast (no meshing) and follow the real count.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numba as nb
import numpy as np
import shapely
from numpy.typing import NDArray

from .boundary import Region
from .conetree import _bound, _cone, build_boxes, slots_meeting
from .errors import Cancelled, LimitExceeded
from .gaps import ring_segments
from .params import SizingParams
from .result import ProgressFn, StopFn
from .sizing import SizeField, SizeTuple, size_field_at

__all__ = [
    "EQUILATERAL_AREA",
    "boundary_nodes",
    "estimate_triangles",
    "front_slope",
    "refuse_by_area",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Weights of the area integral where the field is flat, where it grades in leaves the boundary
#: cuts (the first rows at the boundary, the inside of narrow gaps), where it grades away from
#: the boundary (the front grows row by row and sizes each row near its base, so those rows are
#: about 30% finer than the field), and of the boundary nodes: least squares of the relative
#: error over 30 meshes (the public cases at h and 2h, thin spikes, a channel, a short segment,
#: digitised ellipses and circles of 1,500 to 20,000 vertices, random stars, growth 1.1 and 1.2;
#: benchmarks/estimate_bench.py), all within 0.92-1.10 of the real count.
_WEIGHTS = np.array([0.997, 1.017, 1.302])
_PER_NODE = 0.479
#: Quadtree leaves are at most this many local sizes wide.
_LEAF = 3.0
#: Triangles per unit area of an equilateral mesh with edge h are 1 / (EQUILATERAL_AREA * h^2).
EQUILATERAL_AREA = math.sqrt(3.0) / 4.0
_STACK = 128
#: Quadtree leaves counted between two looks at the cap.
_CHUNK = 1 << 14
#: A piece of a boundary segment is counted whole once the field's least and greatest possible
#: sizes on it are within this fraction.
_NODE_TOL = 0.01
#: ... and only tested when longer than this many local sizes (shorter ones are halved at
#: once: two tree walks cost more than the few lookups they could save).
_TESTED = 8.0
#: The front sizes each row from the field about a row ahead and can only lengthen its edges
#: row by row, so where the field asks to grade steeply (slope ``growth - 1`` above 0.2) it
#: grades more slowly: the slope it reaches, measured as the one whose estimate is closest to
#: the real count over the benchmark set at growth 1.3, 1.5, 2 and 3 (linear in between,
#: constant past the last).
_FRONT_ASKED = np.array([0.0, 0.2, 0.3, 0.5, 1.0, 2.0])
_FRONT_REACHED = np.array([0.0, 0.2, 0.24, 0.36, 0.45, 0.55])


def _no_progress(stage: str, fraction: float) -> None:
    del stage, fraction


def _never() -> bool:
    return False


@nb.njit(cache=True, inline="always")
def _box_gap(
    x0: float, y0: float, x1: float, y1: float, box: tuple[float, float, float, float]
) -> float:  # pragma: no cover - compiled
    """Distance between the box ``x0, y0, x1, y1`` and ``box``."""
    dx = max(x0 - box[2], 0.0, box[0] - x1)
    dy = max(y0 - box[3], 0.0, box[1] - y1)
    return math.sqrt(dx * dx + dy * dy)


@nb.njit(cache=True)
def _field_on(
    sf: SizeTuple, px: float, py: float, qx: float, qy: float, floor: float
) -> float:  # pragma: no cover - compiled
    """Bounds of the size field on the segment ``p -> q``, by one walk of the cone tree.

    ``floor <= 0``: a size the field does not exceed anywhere on it, the least over the
    features of the larger of their cones at its ends (a cone is convex along a line, so it
    peaks at an end). ``floor > 0``: ``floor`` if no node or feature can ask for less anywhere
    in the segment's box (each grows away from its box by its slope), else the first lower
    value found."""
    upper = floor <= 0.0
    best = sf.size if upper else floor
    box = (min(px, qx), min(py, qy), max(px, qx), max(py, qy))
    stack = np.empty(_STACK, dtype=np.int64)
    stack[0] = 0
    top = 1 if sf.hmin.shape[0] else 0
    while top > 0:
        top -= 1
        node = stack[top]
        if upper:
            bound = max(_bound(px, py, sf, node), _bound(qx, qy, sf, node))
        else:
            nb_ = sf.box[node]
            gap = _box_gap(nb_[0], nb_[1], nb_[2], nb_[3], box)
            bound = sf.hmin[node] + sf.smin[node] * gap
        if bound >= best:
            continue
        if sf.child[node, 0] >= 0:
            stack[top], stack[top + 1] = sf.child[node, 0], sf.child[node, 1]
            top += 2
            continue
        for f in range(sf.span[node, 0], sf.span[node, 1]):
            if upper:
                best = min(best, max(_cone(px, py, sf, f), _cone(qx, qy, sf, f)))
                continue
            ax, ay, bx, by = sf.fa[f, 0], sf.fa[f, 1], sf.fb[f, 0], sf.fb[f, 1]
            gap = _box_gap(min(ax, bx), min(ay, by), max(ax, bx), max(ay, by), box)
            low = min(sf.ha[f], sf.hb[f]) + sf.fslope[f] * gap
            if low < floor:
                return low
    return max(best, sf.size_min)


@nb.njit(cache=True)
def boundary_nodes(
    a: FloatArray, b: FloatArray, nxt: IntArray, sf: SizeTuple, cap: float
) -> tuple[float, int]:  # pragma: no cover - compiled
    """Nodes the discretisation puts on segments ``a[i] -> b[i] = a[nxt[i]]`` (their starts
    included), the integral of ``1 / h`` along each, rounded; stops past ``cap``. Also returns
    the size lookups and box tests it took.

    A piece of a segment is counted by the trapezoid rule on its ends' sizes once it is at most
    one local size long, or once the field is known to stay within ``_NODE_TOL`` on it: below
    the upper bound of :func:`_field_on` and above ``1 - _NODE_TOL`` of that. Other pieces
    are halved (untested when under ``_TESTED`` sizes long), so a long side where a gap asks
    for a constant size costs a few lookups, not one per node (a 1e-6-wide spike: 318 instead
    of 8.4 million)."""
    at_vertex = np.empty(a.shape[0])
    for i in range(a.shape[0]):
        at_vertex[i] = size_field_at(sf, a[i, 0], a[i, 1])
    work = a.shape[0]
    pieces = np.empty((_STACK, 4))  # t0, t1, h(t0), h(t1)
    total = 0.0
    for i in range(a.shape[0]):
        ax, ay, bx, by = a[i, 0], a[i, 1], b[i, 0], b[i, 1]
        length = math.hypot(bx - ax, by - ay)
        pieces[0] = (0.0, 1.0, at_vertex[i], at_vertex[nxt[i]])
        top = 1
        cum = 0.0
        while top > 0 and total + cum <= cap:
            top -= 1
            t0, t1, h0, h1 = pieces[top]
            span = (t1 - t0) * length
            done = span <= min(h0, h1) or top + 2 > _STACK
            if not done and span > _TESTED * min(h0, h1):
                px, py = ax + t0 * (bx - ax), ay + t0 * (by - ay)
                qx, qy = ax + t1 * (bx - ax), ay + t1 * (by - ay)
                floor = (1.0 - _NODE_TOL) * _field_on(sf, px, py, qx, qy, 0.0)
                work += 2
                done = floor <= sf.size_min or _field_on(sf, px, py, qx, qy, floor) >= floor
            if done:
                cum += 0.5 * (1.0 / h0 + 1.0 / h1) * span
                continue
            tm = 0.5 * (t0 + t1)
            hm = size_field_at(sf, ax + tm * (bx - ax), ay + tm * (by - ay))
            work += 1
            # The far half below, so pieces are counted from the segment's start.
            pieces[top] = (tm, t1, hm, h1)
            pieces[top + 1] = (t0, tm, h0, hm)
            top += 2
        total += max(round(cum), 1)
        if total > cap:
            break
    return total, work


class _Segments(NamedTuple):
    """Boundary segments ``a[i] -> b[i]`` and a box tree over them, as numba kernels take them
    (see :func:`engine.conetree.build_boxes`)."""

    a: FloatArray
    b: FloatArray
    order: IntArray  #: segment in each tree slot
    box: FloatArray  #: (m, 4) node boxes
    child: IntArray  #: (m, 2) children, -1 for a leaf
    span: IntArray  #: (m, 2) slot range of each node


def _segments(region: Region) -> _Segments:
    a, b, _, _ = ring_segments(region)
    a, b = np.ascontiguousarray(a, np.float64), np.ascontiguousarray(b, np.float64)
    return _Segments(a, b, *build_boxes(a, b))


@nb.njit(cache=True)
def _inside(x: FloatArray, y: FloatArray, segs: _Segments) -> NDArray[np.bool_]:  # pragma: no cover
    """Whether each point lies inside the rings (even-odd crossings of a ray towards +x; the
    tree only opens boxes the ray meets, so a point costs the segments near the ray)."""
    out = np.zeros(x.shape[0], dtype=np.bool_)
    stack = np.empty(_STACK, dtype=np.int64)
    slots = np.empty(segs.order.shape[0], dtype=np.int64)
    for p in range(x.shape[0]):
        px, py = x[p], y[p]
        odd = False
        ray = (px, py, np.inf, py)
        for i in range(slots_meeting(segs.box, segs.child, segs.span, ray, stack, slots)):
            s = segs.order[slots[i]]
            ax, ay, bx, by = segs.a[s, 0], segs.a[s, 1], segs.b[s, 0], segs.b[s, 1]
            if (ay > py) != (by > py) and ax + (py - ay) * (bx - ax) / (by - ay) > px:
                odd = not odd
        out[p] = odd
    return out


@nb.njit(cache=True, inline="always")
def _meets(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float, half: float
) -> bool:  # pragma: no cover - compiled
    """Whether segment ``a -> b`` meets the square of half-side ``half`` around ``c``
    (separating axes: the two boxes, and the segment's normal)."""
    if min(ax, bx) > cx + half or max(ax, bx) < cx - half:
        return False
    if min(ay, by) > cy + half or max(ay, by) < cy - half:
        return False
    cross = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return abs(cross) <= half * (abs(bx - ax) + abs(by - ay))


@nb.njit(cache=True)
def _first_pairs(
    centres: FloatArray, half: float, segs: _Segments
) -> tuple[IntArray, IntArray]:  # pragma: no cover - compiled
    """The (cell, segment) pairs that meet, for squares of half-side ``half`` around
    ``centres``, among the segments the tree finds near each."""
    cells = nb.typed.List.empty_list(nb.int64)
    found = nb.typed.List.empty_list(nb.int64)
    stack = np.empty(_STACK, dtype=np.int64)
    slots = np.empty(segs.order.shape[0], dtype=np.int64)
    for c in range(centres.shape[0]):
        cx, cy = centres[c, 0], centres[c, 1]
        square = (cx - half, cy - half, cx + half, cy + half)
        for i in range(slots_meeting(segs.box, segs.child, segs.span, square, stack, slots)):
            s = segs.order[slots[i]]
            if _meets(segs.a[s, 0], segs.a[s, 1], segs.b[s, 0], segs.b[s, 1], cx, cy, half):
                cells.append(c)
                found.append(s)
    out_cell = np.empty(len(cells), dtype=np.int64)
    out_seg = np.empty(len(cells), dtype=np.int64)
    for i in range(len(cells)):
        out_cell[i], out_seg[i] = cells[i], found[i]
    return out_cell, out_seg


@nb.njit(cache=True)
def _child_pairs(
    parent: IntArray, seg: IntArray, centres: FloatArray, segs: _Segments, quarter: float
) -> tuple[IntArray, IntArray]:  # pragma: no cover - compiled
    """The (child, segment) pairs that meet, from the (parent, segment) pairs that do: child
    ``k`` of split parent ``p`` is ``centres[k * ns + p]``, a square of half-side ``quarter``
    (separating axes: the two boxes, and the segment's normal)."""
    ns = centres.shape[0] // 4
    out_cell = np.empty(4 * parent.shape[0], dtype=np.int64)
    out_seg = np.empty(4 * parent.shape[0], dtype=np.int64)
    n = 0
    for i in range(parent.shape[0]):
        s = seg[i]
        ax, ay, bx, by = segs.a[s, 0], segs.a[s, 1], segs.b[s, 0], segs.b[s, 1]
        for k in range(4):
            c = k * ns + parent[i]
            if _meets(ax, ay, bx, by, centres[c, 0], centres[c, 1], quarter):
                out_cell[n], out_seg[n] = c, s
                n += 1
    return out_cell[:n], out_seg[:n]


class _Level(NamedTuple):
    """One quadtree level: cell centres, whether each lies inside the region (1), outside (0)
    or is cut by the boundary or not yet known (-1), and the (cell, segment) pairs that meet."""

    centres: FloatArray
    inside: NDArray[np.int8]
    pair_cell: IntArray
    pair_seg: IntArray


def _children(lv: _Level, split: NDArray[np.bool_], cell: float, segs: _Segments) -> _Level:
    """The four children of each split cell; a child only meets the segments its parent met,
    and a child of a cell the boundary does not cut lies on the same side as its parent."""
    quarter = 0.25 * cell
    ns = int(split.sum())
    offs = np.array([[-1.0, -1.0], [-1.0, 1.0], [1.0, -1.0], [1.0, 1.0]]) * quarter
    centres = (lv.centres[split][None, :, :] + offs[:, None, :]).reshape(-1, 2)
    index = np.full(len(lv.centres), -1)
    index[split] = np.arange(ns)
    keep = index[lv.pair_cell] >= 0
    pc, ps = _child_pairs(index[lv.pair_cell[keep]], lv.pair_seg[keep], centres, segs, quarter)
    return _Level(centres, np.tile(lv.inside[split], 4), pc, ps)


@nb.njit(cache=True, inline="always")
def _left(ax: float, ay: float, bx: float, by: float, px: float, py: float) -> bool:
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax) > 0.0  # pragma: no cover - compiled


@nb.njit(cache=True)
def _cut_shares(
    centres: FloatArray,
    cells: IntArray,
    start: IntArray,
    seg: IntArray,
    segs: _Segments,
    cell: float,
) -> FloatArray:  # pragma: no cover - compiled
    """Share of a 4 x 4 grid of samples inside the region, for each cut cell: the centre's side
    from one ray across the rings, each sample's from the crossings of its path to the centre
    with the segments ``seg[start[c]:start[c + 1]]`` that meet cell ``c`` (the path stays in the
    cell), so a cell costs one ray, not sixteen."""
    out = np.empty(cells.shape[0])
    centre_in = _inside(centres[cells, 0], centres[cells, 1], segs)
    for i in range(cells.shape[0]):
        c = cells[i]
        cx, cy = centres[c, 0], centres[c, 1]
        count = 0
        for j in range(4):
            for k in range(4):
                sx, sy = cx + (k - 1.5) * (cell / 4), cy + (j - 1.5) * (cell / 4)
                odd = centre_in[i]
                for p in range(start[c], start[c + 1]):
                    s = seg[p]
                    ax, ay, bx, by = segs.a[s, 0], segs.a[s, 1], segs.b[s, 0], segs.b[s, 1]
                    if _left(sx, sy, cx, cy, ax, ay) != _left(sx, sy, cx, cy, bx, by) and _left(
                        ax, ay, bx, by, sx, sy
                    ) != _left(ax, ay, bx, by, cx, cy):
                        odd = not odd
                count += odd
        out[i] = count / 16.0
    return out


def _by_cell(lv: _Level) -> tuple[IntArray, IntArray]:
    """The level's pairs grouped by cell: cell ``c`` meets ``seg[start[c]:start[c + 1]]``."""
    start = np.zeros(len(lv.centres) + 1, dtype=np.int64)
    np.cumsum(np.bincount(lv.pair_cell, minlength=len(lv.centres)), out=start[1:])
    return start, lv.pair_seg[np.argsort(lv.pair_cell, kind="stable")]


def _leaf_share(
    lv: _Level, ids: IntArray, cell: float, segs: _Segments, by_cell: tuple[IntArray, IntArray]
) -> FloatArray:
    """Area of each square leaf ``ids`` inside the region, over ``EQUILATERAL_AREA``: known
    for leaves the boundary does not cut, a 4 x 4 grid of samples for the others (a leaf is at
    most ``_LEAF`` local sizes wide, and gaps ask for sizes below ``_LEAF / 4`` of their width,
    so the grid sees them)."""
    share = lv.inside[ids].astype(np.float64)
    cut = np.flatnonzero(share < 0)
    if len(cut):
        share[cut] = _cut_shares(lv.centres, ids[cut], *by_cell, segs, cell)
    return share * (cell * cell / EQUILATERAL_AREA)


def front_slope(slope: FloatArray) -> FloatArray:
    """The slope the front achieves where the field asks for ``slope`` (``growth - 1``).

    >>> front_slope(np.array([0.1, 0.2, 0.5, 1.0, 4.0])).round(3).tolist()
    [0.1, 0.2, 0.36, 0.45, 0.55]
    """
    asked = np.asarray(slope, np.float64)
    return np.minimum(asked, np.interp(asked, _FRONT_ASKED, _FRONT_REACHED))


def _as_the_front_grades(field: SizeField) -> SizeField:
    """``field`` with each feature's slope replaced by what the front achieves."""
    t = field.tree
    fslope = front_slope(t.fslope)
    slope = float(front_slope(np.array(t.slope)))
    if slope == t.slope and np.array_equal(fslope, t.fslope):
        return field
    # The slope is increasing in what is asked, so a node's least slope maps to its least.
    tree = t._replace(slope=slope, fslope=fslope, smin=front_slope(t.smin))
    return dataclasses.replace(field, tree=tree)


def _area_integral(
    region: Region, field: SizeField, max_cells: int, cap: float, should_stop: StopFn
) -> FloatArray:
    """Integrals of ``1 / (EQUILATERAL_AREA h^2)`` over the region where the field is flat,
    where it grades in leaves the boundary cuts and where it grades in the others, on an
    adaptive quadtree whose cells are split while wider than ``_LEAF`` times the size at their
    centre; stops once their sum weighted by ``_WEIGHTS`` passes ``cap``.

    A graded leaf's midpoint value is scaled by ``1 / (1 - (slope cell / 2 h)^2)``, the exact
    integral of ``1 / h^2`` across a cell where ``h`` grows linearly along one side (the field
    grows by ``slope`` away from its features), so leaves may be a few sizes wide. Which
    segments cut a cell is inherited from its parent (a box tree over the segments finds them on
    the first level), and whether an uncut cell is inside too, so point-in-region tests are only
    taken next to the boundary."""
    segs = _segments(region)
    x0, y0, x1, y1 = region.bounds
    cell = field.size
    nx = max(math.ceil((x1 - x0) / cell), 1)
    ny = max(math.ceil((y1 - y0) / cell), 1)
    while nx * ny > max_cells:
        cell *= 2.0
        nx, ny = max(math.ceil((x1 - x0) / cell), 1), max(math.ceil((y1 - y0) / cell), 1)
    gx, gy = np.meshgrid(x0 + cell * (np.arange(nx) + 0.5), y0 + cell * (np.arange(ny) + 0.5))
    centres = np.c_[gx.ravel(), gy.ravel()]
    pair_cell, pair_seg = _first_pairs(centres, 0.5 * cell, segs)
    lv = _Level(centres, np.full(len(centres), -1, np.int8), pair_cell, pair_seg)
    sums = np.zeros(3)
    # Sizes strictly between the clamps grade (the field's slope there is ``slope``).
    top, bottom = field.size * (1.0 - 1e-9), field.size_min * (1.0 + 1e-9)
    while len(lv.centres) and sums @ _WEIGHTS <= cap:
        if should_stop():
            raise Cancelled("stopped while estimating the mesh")
        cut = np.zeros(len(lv.centres), dtype=np.bool_)
        cut[lv.pair_cell] = True
        known = (lv.inside >= 0) | cut
        todo = np.flatnonzero(~known)
        pts = lv.centres[todo]
        lv.inside[todo] = _inside(pts[:, 0], pts[:, 1], segs)
        lv.inside[cut] = -1
        # A cell wholly outside adds nothing and is never split: no size is taken there.
        h = np.full(len(lv.centres), np.inf)
        some = lv.inside != 0
        h[some] = field(lv.centres[some])
        split = h * _LEAF < cell
        if len(lv.centres) + 3 * int(split.sum()) > max_cells:
            split[:] = False  # out of cells: count the rest at their centre size
        leaves = np.flatnonzero(~split)
        by_cell = _by_cell(lv)
        # Chunks, so that a cap is noticed within a level and not only after it.
        for lo in range(0, len(leaves), _CHUNK):
            ids = leaves[lo : lo + _CHUNK]
            hl = h[ids]
            share = _leaf_share(lv, ids, cell, segs, by_cell) / hl**2
            ramp = (hl < top) & (hl > bottom)
            free = ramp & (lv.inside[ids] >= 0)
            spread = np.minimum(0.5 * field.slope * cell / hl[free], 0.5)
            sums += (
                share[~ramp].sum(), share[ramp & ~free].sum(),
                (share[free] / (1.0 - spread**2)).sum(),
            )  # fmt: skip
            if sums @ _WEIGHTS > cap:
                return sums
        lv = _children(lv, split, cell, segs)
        cell *= 0.5
    return sums


def _area_low(region: Region, h_max: float) -> float:
    """A lower bound on the area term of :func:`estimate_triangles` where no size exceeds
    ``h_max``: the region's area at that size."""
    return float(_WEIGHTS.min() * region.area / (EQUILATERAL_AREA * h_max * h_max))


def refuse_by_area(region: Region, sizing: SizingParams, cap: int) -> None:
    """Raise :class:`LimitExceeded` when even a mesh at the plain size everywhere (no size
    exceeds it), or inside one refinement polygon at its size, has more than ``cap``
    triangles: checked before the size field is built, whose cost grows with the boundary's
    length (and a refinement polygon's height) over the size.

    >>> from engine import make_region
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> try:
    ...     refuse_by_area(square, SizingParams(size=1e-6), 1_000_000)
    ... except LimitExceeded as exc:
    ...     print(exc.estimate)
    2302472873529
    """
    size = sizing.size if sizing.size_max is None else min(sizing.size, sizing.size_max)
    low = _area_low(region, max(size, sizing.size_min or 0.0))
    what = f"the region's area at the size {size:g}"
    # A refinement polygon's area inside the region at its size, alone.
    areas = [(i, r, g) for i, r in enumerate(sizing.refinements) if (g := r.shape()).area > 0]
    shape = region.to_shapely() if areas else None
    for i, r, geom in areas:
        inside = float(shapely.intersection(geom, shape).area)
        if (own := _WEIGHTS.min() * inside / (EQUILATERAL_AREA * r.size * r.size)) > low:
            low, what = own, f"refinement {i}'s area at its size {r.size:g}"
    if low > cap:
        least = math.ceil(low)
        raise LimitExceeded(
            f"the estimated number of triangles is at least {least} ({what}), over the limit "
            f"of {cap}; use a larger size",
            limit=cap,
            estimate=least,
        )


def estimate_triangles(
    region: Region,
    field: SizeField,
    max_cells: int = 1 << 19,
    cap: int | None = None,
    progress: ProgressFn | None = None,
    should_stop: StopFn | None = None,
) -> int:
    """Expected triangle count of the mesh of ``region`` following ``field``.

    The larger of the area term (the integral of ``1 / (sqrt(3)/4 h^2)`` on an adaptive
    quadtree, weighted by where the field is flat, grades at the boundary or grades away from
    it, plus a share per boundary node) and the boundary term (a triangulation of ``n``
    boundary nodes has at least ``n - 2 + 2 * holes`` triangles: what thin features and
    digitised boundaries cost).
    Counting stops once the estimate is past ``cap``: the result is then only known to exceed it.

    >>> from engine import SizingParams, make_region
    >>> from engine.sizing import build_size_field
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> estimate_triangles(square, build_size_field(square, SizingParams(size=0.1)))
    249
    """
    progress = progress or _no_progress
    should_stop = should_stop or _never
    limit = float(cap) if cap is not None else math.inf
    progress("estimate", 0.0)
    # No size exceeds the field's plain size, so the region's area at that size is a lower bound
    # on the area term: a cap it already passes is refused before any counting.
    area_low = _area_low(region, max(field.size, field.size_min))
    if area_low > limit:
        return math.ceil(area_low)
    a, b, _, nxt = ring_segments(region)
    nodes, _ = boundary_nodes(a, b, nxt, field.as_tuple(), limit)
    if nodes > limit or area_low + _PER_NODE * nodes > limit:
        return round(max(nodes, area_low + _PER_NODE * nodes))  # at least this many triangles
    holes = len(region.rings) - len(region.parts)
    edge = nodes - 2 * len(region.parts) + 2 * holes
    progress("estimate", 0.5)
    # The area term passes the cap once the weighted integrals pass this.
    graded = _as_the_front_grades(field)
    sums = _area_integral(region, graded, max_cells, limit - _PER_NODE * nodes, should_stop)
    progress("estimate", 1.0)
    return round(max(float(sums @ _WEIGHTS) + _PER_NODE * nodes, edge))
