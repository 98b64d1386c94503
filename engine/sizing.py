"""Graded size field: the target edge length at every point of the region.

The field is the lower envelope of cones ``h(x) = min(size, min_f h_f + (growth - 1) * |x - f|)``
over *features* ``f`` of the boundary that ask for edges shorter than ``size``, clamped to
``[size_min, size_max]``. Moving one element of length ``h`` away from a feature raises the size by
``(growth - 1) * h``, so neighbouring elements differ by at most the factor ``growth``.

Features:

- short boundary segments: each input vertex asks for the length of its shorter segment;
- narrow gaps: a boundary point facing another part of the boundary across the region at distance
  ``w`` asks for ``GAP_FACTOR * w`` (about two layers of triangles across);
- sharp corners: a convex corner of angle ``theta`` below 60 degrees asks for
  ``size * theta / 60`` at its tip.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np
import shapely
from numpy.typing import NDArray

from .boundary import Region
from .conetree import ConeTree, build_tree, cone_min
from .errors import Cancelled, LimitExceeded
from .params import SizingParams
from .refinement import refinement_features
from .result import ProgressFn, StopFn

__all__ = [
    "GAP_FACTOR",
    "MAX_GAP_SAMPLES",
    "SizeField",
    "SizeTuple",
    "build_size_field",
    "estimate_triangles",
    "size_field_at",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
#: The size field as numba kernels take it (see :meth:`SizeField.as_tuple`).
SizeTuple = ConeTree

#: Size asked for by a narrow gap, as a fraction of its width (two rows of triangles across).
GAP_FACTOR = 0.6
#: Cosine of the widest angle between a boundary point's inward normal and the direction to the
#: boundary it faces for the two to count as a gap (60 degrees: sharper corners count as gaps).
_FACING_COS = 0.5
_SHARP_CORNER_DEG = 60.0
#: Gap samples (each one STRtree query) that one size field may take; past it the region is
#: refused, since a mesh needs at least one boundary node per sample.
MAX_GAP_SAMPLES = 2_000_000
#: A piece of boundary whose gap width is linear within this fraction becomes one feature.
_LINEAR_TOL = 0.02
#: The estimate's weights of the area integral and of the boundary nodes (the front's rows near
#: the boundary are a little finer than the field): least squares over the public cases, thin
#: spikes, a channel, a digitised ellipse and a random star (tests/engine/test_estimate.py).
_PER_AREA, _PER_NODE = 1.04, 0.3
#: Triangles per unit area of an equilateral mesh with edge h are 1 / (EQUILATERAL_AREA * h^2).
EQUILATERAL_AREA = math.sqrt(3.0) / 4.0
#: Quadtree leaves counted between two looks at the cap.
_CHUNK = 1 << 14


def _no_progress(stage: str, fraction: float) -> None:
    del stage, fraction


def _never() -> bool:
    return False


@dataclass(frozen=True)
class SizeField:
    """A size function; call it with an ``(k, 2)`` array of points.

    >>> from engine.boundary import make_region
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> field = build_size_field(square, SizingParams(size=0.1))
    >>> field(np.array([[0.5, 0.5]])).tolist()
    [0.1]
    """

    tree: ConeTree  #: features and the tree over them
    samples: int = 0  #: gap samples the field took to build

    def __call__(self, xy: FloatArray) -> FloatArray:
        return self.evaluate(xy)[0]

    def evaluate(self, xy: FloatArray) -> tuple[FloatArray, int]:
        """Sizes at ``xy`` and the number of feature evaluations they took."""
        pts = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        return _evaluate(pts, self.tree)

    @property
    def size(self) -> float:
        """Target size away from features (already clamped)."""
        return self.tree.size

    @property
    def slope(self) -> float:
        """``growth - 1``."""
        return self.tree.slope

    @property
    def size_min(self) -> float:
        """Lower clamp (0 when none)."""
        return self.tree.size_min

    @property
    def feature_h(self) -> FloatArray:
        """Smallest size each feature asks for."""
        return np.minimum(self.tree.ha, self.tree.hb)

    @property
    def smallest(self) -> float:
        """Smallest size the field asks for anywhere."""
        h = float(self.feature_h.min()) if self.feature_h.size else self.size
        return max(min(h, self.size), self.size_min)

    def as_tuple(self) -> ConeTree:
        """The named tuple that numba kernels take (see :func:`size_field_at`)."""
        return self.tree


@nb.njit(cache=True, inline="always")
def size_field_at(sf: SizeTuple, x: float, y: float) -> float:
    """The size field at one point, from :meth:`SizeField.as_tuple` (numba)."""
    return cone_min(sf, x, y)[0]


@nb.njit(cache=True, nogil=True)
def _evaluate(pts: FloatArray, t: ConeTree) -> tuple[FloatArray, int]:  # pragma: no cover
    out = np.empty(pts.shape[0])
    work = 0
    for p in range(pts.shape[0]):
        out[p], w = cone_min(t, pts[p, 0], pts[p, 1])
        work += w
    return out, work


@nb.njit(cache=True)
def boundary_nodes(
    a: FloatArray, b: FloatArray, sf: SizeTuple, cap: float
) -> float:  # pragma: no cover - compiled
    """Nodes the discretisation puts on segments ``a[i] -> b[i]`` (their starts included), in
    steps of the local size (it changes by at most ``slope`` a step); stops past ``cap``."""
    total = 0.0
    for i in range(a.shape[0]):
        ax, ay, bx, by = a[i, 0], a[i, 1], b[i, 0], b[i, 1]
        length = math.hypot(bx - ax, by - ay)
        h_prev = size_field_at(sf, ax, ay)
        t, cum = 0.0, 0.0
        while t < 1.0 and total + cum <= cap:
            step = min(h_prev / length, 1.0 - t)
            t += step
            h = size_field_at(sf, ax + t * (bx - ax), ay + t * (by - ay))
            cum += 0.5 * (1.0 / h + 1.0 / h_prev) * step * length
            h_prev = h
        total += max(round(cum), 1)
        if total > cap:
            break
    return total


def _ring_segments(region: Region) -> tuple[FloatArray, FloatArray, IntArray, IntArray]:
    """Segment starts and ends of every ring, and the previous / next segment of each."""
    starts, prev, nxt = [], [], []
    offset = 0
    for ring in region.rings:
        n = len(ring)
        starts.append(ring)
        idx = np.arange(n)
        prev.append(offset + (idx - 1) % n)
        nxt.append(offset + (idx + 1) % n)
        offset += n
    a = np.concatenate(starts)
    b = np.concatenate([np.roll(r, -1, axis=0) for r in region.rings])
    return a, b, np.concatenate(prev), np.concatenate(nxt)


def _vertex_features(
    a: FloatArray, b: FloatArray, prev: IntArray, size: float
) -> tuple[FloatArray, FloatArray]:
    """Short segments and sharp convex corners, as features at the input vertices."""
    seg = b - a
    length = np.hypot(seg[:, 0], seg[:, 1])
    h = np.minimum(length, length[prev])
    # Interior angle at vertex a[i] between the incoming segment prev[i] and the outgoing one i;
    # the region is on the left of every ring.
    din = seg[prev]
    cross = din[:, 0] * seg[:, 1] - din[:, 1] * seg[:, 0]
    dot = (din * seg).sum(axis=1)
    turn = np.degrees(np.arctan2(cross, dot))  # left turn positive
    interior = 180.0 - turn
    sharp = interior < _SHARP_CORNER_DEG
    h = np.where(sharp, np.minimum(h, size * interior / _SHARP_CORNER_DEG), h)
    keep = h < size
    return a[keep], h[keep]


def _gap_sizes(
    samples: FloatArray,
    normals: FloatArray,
    seg_of_sample: IntArray,
    a: FloatArray,
    b: FloatArray,
    prev: IntArray,
    nxt: IntArray,
    tree: shapely.STRtree,
    reach: FloatArray,
) -> FloatArray:
    """Size each sample asks for because it faces another part of the boundary within its
    ``reach`` (per sample: gaps wider than that ask for no less than the sample has)."""
    out = np.full(len(samples), np.inf)
    chunk = 200_000
    for lo in range(0, len(samples), chunk):
        sl = slice(lo, lo + chunk)
        s_idx, g_idx = tree.query(
            shapely.points(samples[sl]), predicate="dwithin", distance=reach[sl]
        )
        s_idx = s_idx + lo
        own = seg_of_sample[s_idx]
        p = samples[s_idx]
        sa, sb = a[g_idx], b[g_idx]
        d = sb - sa
        t = np.clip(((p - sa) * d).sum(axis=1) / np.maximum((d * d).sum(axis=1), 1e-300), 0, 1)
        q = sa + t[:, None] * d
        v = q - p
        dist = np.hypot(v[:, 0], v[:, 1])
        ln = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-300)
        n_q = np.stack([-d[:, 1], d[:, 0]], axis=1) / ln[:, None]
        n_p = normals[s_idx]
        facing = ((v * n_p).sum(axis=1) > _FACING_COS * dist) & (
            (-v * n_q).sum(axis=1) > _FACING_COS * dist
        )
        # Adjacent segments meet at a corner: the corner feature covers that wedge.
        adjacent = (g_idx == own) | (g_idx == prev[own]) | (g_idx == nxt[own])
        ok = facing & ~adjacent & (dist > 0)
        np.minimum.at(out, s_idx[ok], GAP_FACTOR * dist[ok])
    return out


class _Intervals(NamedTuple):
    """Pieces ``t0 -> t1`` of boundary segments and the gap width found at each end."""

    seg: IntArray
    t0: FloatArray
    t1: FloatArray
    g0: FloatArray
    g1: FloatArray

    def take(self, keep: NDArray[np.bool_]) -> _Intervals:
        return _Intervals(self.seg[keep], self.t0[keep], self.t1[keep], self.g0[keep],
                          self.g1[keep])  # fmt: skip

    @staticmethod
    def join(parts: list[_Intervals]) -> _Intervals:
        return _Intervals(
            np.concatenate([p.seg for p in parts]), np.concatenate([p.t0 for p in parts]),
            np.concatenate([p.t1 for p in parts]), np.concatenate([p.g0 for p in parts]),
            np.concatenate([p.g1 for p in parts]),
        )  # fmt: skip


def _gap_features(
    region: Region, vertex_field: SizeField, should_stop: StopFn
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, int]:
    """Segment features from narrow gaps, and the number of samples taken.

    Each segment is cut into pieces no longer than ``size / 2`` and a piece is bisected until
    the gap across it is linear (within ``_LINEAR_TOL``) or the piece is no longer than the size
    the gap asks for. A long thin spike of parallel sides is thus a few linear pieces, not one
    sample per ``GAP_FACTOR * width``. A sample looks for gaps only as far as they could ask
    for less than ``vertex_field`` does there (a wider gap's cone lies above the field
    everywhere, since the field grows no faster than the cone), so a finely digitised
    boundary does not query every segment within ``size / GAP_FACTOR``.
    """
    size, slope = vertex_field.size, vertex_field.slope
    a, b, prev, nxt = _ring_segments(region)
    seg = b - a
    length = np.hypot(seg[:, 0], seg[:, 1])
    normal = np.stack([-seg[:, 1], seg[:, 0]], axis=1) / np.maximum(length, 1e-300)[:, None]
    tree = shapely.STRtree(shapely.linestrings(np.stack([a, b], axis=1)))

    def gap(seg_id: IntArray, t: FloatArray) -> FloatArray:
        pts = a[seg_id] + t[:, None] * seg[seg_id]
        reach = vertex_field(pts) / GAP_FACTOR
        return _gap_sizes(pts, normal[seg_id], seg_id, a, b, prev, nxt, tree, reach) / GAP_FACTOR

    counts = np.maximum(np.ceil(2.0 * length / size).astype(np.int64), 1)
    seg_id = np.repeat(np.arange(len(a)), counts)
    k = np.arange(len(seg_id)) - np.repeat(np.cumsum(counts) - counts, counts)
    t0, t1 = k / counts[seg_id], (k + 1) / counts[seg_id]
    ends = gap(np.concatenate([seg_id, seg_id]), np.concatenate([t0, t1]))
    todo = _Intervals(seg_id, t0, t1, ends[: len(t0)], ends[len(t0) :])
    samples = len(ends)
    out: list[_Intervals] = []
    for _ in range(64):
        if len(todo.seg) == 0:
            break
        if should_stop():
            raise Cancelled("stopped while sizing")
        samples += len(todo.seg)
        if samples > MAX_GAP_SAMPLES:
            raise LimitExceeded(
                f"the region's narrow gaps need more than {MAX_GAP_SAMPLES} boundary samples at "
                "this size (a feature far thinner than the size); use a larger size or remove it",
                limit=MAX_GAP_SAMPLES,
                estimate=samples,
            )
        mid = 0.5 * (todo.t0 + todo.t1)
        gm = gap(todo.seg, mid)
        g = np.stack([todo.g0, gm, todo.g1])
        found = np.isfinite(g)
        g_low = g.min(axis=0)
        g = np.where(found, g, 0.0)  # only pieces found at all three samples can be linear
        piece = (todo.t1 - todo.t0) * length[todo.seg]
        rate = GAP_FACTOR * np.abs(g[2] - g[0]) / np.maximum(piece, 1e-300)
        linear = (
            found.all(axis=0)
            & (np.abs(g[1] - 0.5 * (g[0] + g[2])) <= _LINEAR_TOL * g_low)
            & (rate < slope)
        )
        short = ~linear & np.isfinite(g_low) & (piece <= GAP_FACTOR * g_low)
        out.append(todo.take(linear))
        out.append(_Intervals(todo.seg, todo.t0, todo.t1, g_low, g_low).take(short))
        split = ~linear & ~short & np.isfinite(g_low)
        left = _Intervals(todo.seg, todo.t0, mid, todo.g0, gm).take(split)
        right = _Intervals(todo.seg, mid, todo.t1, gm, todo.g1).take(split)
        todo = _Intervals.join([left, right])
    got = _Intervals.join(out or [todo])
    fa = a[got.seg] + got.t0[:, None] * seg[got.seg]
    fb = a[got.seg] + got.t1[:, None] * seg[got.seg]
    return fa, fb, GAP_FACTOR * got.g0, GAP_FACTOR * got.g1, samples


def build_size_field(
    region: Region,
    params: SizingParams,
    progress: ProgressFn | None = None,
    should_stop: StopFn | None = None,
) -> SizeField:
    """The graded size field of ``region`` for ``params``.

    Raises :class:`LimitExceeded` when the region's gaps need more than
    :data:`MAX_GAP_SAMPLES` samples, and :class:`Cancelled` when ``should_stop()`` is true.
    """
    progress = progress or _no_progress
    should_stop = should_stop or _never
    progress("sizing", 0.0)
    size = params.size
    if params.size_max is not None:
        size = min(size, params.size_max)
    size_min = params.size_min or 0.0
    slope = params.growth - 1.0
    a, b, prev, _ = _ring_segments(region)
    vxy, vh = _vertex_features(a, b, prev, size)
    x0, y0, _, _ = region.bounds
    vertex_field = SizeField(build_tree(size, slope, 0.0, (x0, y0), vxy, vxy, vh, vh))
    progress("sizing", 0.2)
    if should_stop():
        raise Cancelled("stopped while sizing")
    ga, gb, g0, g1, samples = _gap_features(region, vertex_field, should_stop)
    progress("sizing", 0.8)
    # Refinements are point features too, each growing at its own rate.
    rxy, rh, rslope = refinement_features(params.refinements, params.growth)
    fa, fb = np.concatenate([vxy, ga, rxy]), np.concatenate([vxy, gb, rxy])
    ha = np.maximum(np.concatenate([vh, g0, rh]), size_min)
    hb = np.maximum(np.concatenate([vh, g1, rh]), size_min)
    slopes = np.concatenate([np.full(len(vh) + len(g0), slope), rslope])
    keep = np.minimum(ha, hb) < size
    tree = build_tree(
        size, slope, size_min, (x0, y0), fa[keep], fb[keep], ha[keep], hb[keep], slopes[keep]
    )
    progress("sizing", 1.0)
    return SizeField(tree, samples)


class _Segments(NamedTuple):
    """Boundary segments ``a[i] -> b[i]`` as numba kernels take them."""

    a: FloatArray
    b: FloatArray


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
        reach = quarter * (abs(bx - ax) + abs(by - ay))
        for k in range(4):
            c = k * ns + parent[i]
            cx, cy = centres[c, 0], centres[c, 1]
            if min(ax, bx) > cx + quarter or max(ax, bx) < cx - quarter:
                continue
            if min(ay, by) > cy + quarter or max(ay, by) < cy - quarter:
                continue
            if abs((bx - ax) * (cy - ay) - (by - ay) * (cx - ax)) > reach:
                continue
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


def _leaf_share(shape: shapely.Geometry, centres: FloatArray, inside: NDArray[np.int8],
                cell: float) -> FloatArray:  # fmt: skip
    """Area of each square leaf inside the region, over ``EQUILATERAL_AREA``: known for leaves
    the boundary does not cut, a 4 x 4 grid of samples for the others (a leaf is at most twice
    the local size, and gaps ask for sizes below their width, so the grid sees them)."""
    share = inside.astype(np.float64)
    cut = np.flatnonzero(inside < 0)
    if len(cut):
        off = (np.arange(4) - 1.5) * (cell / 4)
        sub = centres[cut, None, :] + np.stack(np.meshgrid(off, off), -1).reshape(1, 16, 2)
        got = shapely.contains_xy(shape, sub[..., 0].ravel(), sub[..., 1].ravel())
        share[cut] = got.reshape(-1, 16).mean(axis=1)
    return share * (cell * cell / EQUILATERAL_AREA)


def _area_integral(
    region: Region, field: SizeField, max_cells: int, cap: float, should_stop: StopFn
) -> float:
    """Integral of ``1 / (EQUILATERAL_AREA h^2)`` over the region on an adaptive quadtree whose
    cells are split while larger than twice the size at their centre; stops past ``cap``.

    Which segments cut a cell is inherited from its parent (one STRtree query, on the first
    level), and whether an uncut cell is inside too, so point-in-region tests are only taken
    next to the boundary."""
    shape = region.to_shapely()
    shapely.prepare(shape)
    a, b, _, _ = _ring_segments(region)
    x0, y0, x1, y1 = region.bounds
    cell = field.size
    nx = max(math.ceil((x1 - x0) / cell), 1)
    ny = max(math.ceil((y1 - y0) / cell), 1)
    while nx * ny > max_cells:
        cell *= 2.0
        nx, ny = max(math.ceil((x1 - x0) / cell), 1), max(math.ceil((y1 - y0) / cell), 1)
    gx, gy = np.meshgrid(x0 + cell * (np.arange(nx) + 0.5), y0 + cell * (np.arange(ny) + 0.5))
    centres = np.c_[gx.ravel(), gy.ravel()]
    segs = _Segments(np.ascontiguousarray(a), np.ascontiguousarray(b))
    edges = shapely.STRtree(shapely.linestrings(np.stack([a, b], axis=1)))
    boxes = shapely.box(*(centres - 0.5 * cell).T, *(centres + 0.5 * cell).T)
    pair_cell, pair_seg = edges.query(boxes, predicate="intersects")
    lv = _Level(centres, np.full(len(centres), -1, np.int8), pair_cell, pair_seg)
    total = 0.0
    while len(lv.centres) and total <= cap:
        if should_stop():
            raise Cancelled("stopped while estimating the mesh")
        h = field(lv.centres)
        split = h < 0.5 * cell
        if len(lv.centres) + 3 * int(split.sum()) > max_cells:
            split[:] = False  # out of cells: count the rest at their centre size
        cut = np.zeros(len(lv.centres), dtype=np.bool_)
        cut[lv.pair_cell] = True
        known = (lv.inside >= 0) | cut
        todo = np.flatnonzero(~known)
        pts = lv.centres[todo]
        lv.inside[todo] = shapely.contains_xy(shape, pts[:, 0], pts[:, 1])
        lv.inside[cut] = -1
        leaves = np.flatnonzero(~split)
        # Chunks, so that a cap is noticed within a level and not only after it.
        for lo in range(0, len(leaves), _CHUNK):
            ids = leaves[lo : lo + _CHUNK]
            share = _leaf_share(shape, lv.centres[ids], lv.inside[ids], cell)
            total += float(np.sum(share / h[ids] ** 2))
            if total > cap:
                return total
        lv = _children(lv, split, cell, segs)
        cell *= 0.5
    return total


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
    quadtree, plus a share per boundary node) and the boundary term (a triangulation of ``n``
    boundary nodes has at least ``n - 2 + 2 * holes`` triangles: what thin features and
    digitised boundaries cost).
    Counting stops once the estimate is past ``cap``: the result is then only known to exceed it.

    >>> from engine.boundary import make_region
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> estimate_triangles(square, build_size_field(square, SizingParams(size=0.1)))
    252
    """
    progress = progress or _no_progress
    should_stop = should_stop or _never
    limit = float(cap) if cap is not None else math.inf
    progress("estimate", 0.0)
    # No size exceeds the field's plain size, so the region's area at that size is a lower bound
    # on the area term: a cap it already passes is refused before any counting.
    h_max = max(field.size, field.size_min)
    area_low = _PER_AREA * region.area / (EQUILATERAL_AREA * h_max * h_max)
    if area_low > limit:
        return math.ceil(area_low)
    a, b, _, _ = _ring_segments(region)
    nodes = boundary_nodes(a, b, field.as_tuple(), limit)
    if nodes > limit or area_low + _PER_NODE * nodes > limit:
        return round(max(nodes, area_low + _PER_NODE * nodes))  # at least this many triangles
    holes = len(region.rings) - len(region.parts)
    edge = nodes - 2 * len(region.parts) + 2 * holes
    progress("estimate", 0.5)
    # The cap in the integral's units: the area term passes it once the integral passes this.
    area_cap = (limit - _PER_NODE * nodes) / _PER_AREA
    area = _area_integral(region, field, max_cells, area_cap, should_stop)
    progress("estimate", 1.0)
    return round(max(_PER_AREA * area + _PER_NODE * nodes, edge))
