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

from dataclasses import dataclass
from typing import NamedTuple

import numba as nb
import numpy as np
from numpy.typing import NDArray

from .boundary import Region
from .conetree import ConeTree, build_tree, cone_min
from .errors import Cancelled, LimitExceeded
from .gaps import gap_search, gap_widths, ring_segments
from .params import SizingParams
from .refinement import refinement_features
from .result import ProgressFn, StopFn

__all__ = [
    "GAP_FACTOR",
    "MAX_GAP_SAMPLES",
    "SizeField",
    "SizeTuple",
    "build_size_field",
    "size_field_at",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
#: The size field as numba kernels take it (see :meth:`SizeField.as_tuple`).
SizeTuple = ConeTree

#: Size asked for by a narrow gap, as a fraction of its width (two rows of triangles across).
GAP_FACTOR = 0.6
_SHARP_CORNER_DEG = 60.0
#: Gap samples (each one search of the boundary near it) that one size field may take; past it
#: the region is refused, since a mesh needs at least one boundary node per sample.
MAX_GAP_SAMPLES = 2_000_000
#: The field's smallest size must span at least this many representable steps (``np.spacing``)
#: of the region's largest coordinate. Meshes measured at 1e9 and 1e10 from the origin: 84 steps,
#: worst radius ratio 0.89; 5, 0.85; 1.6, 0.68; 0.5 steps, coincident points.
RESOLUTION_STEPS = 16
#: A piece of boundary whose gap width is linear within this fraction becomes one feature.
_LINEAR_TOL = 0.02


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
    search = gap_search(region, vertex_field.tree, GAP_FACTOR)
    a, seg = search.a, search.b - search.a
    length = np.hypot(seg[:, 0], seg[:, 1])

    def gap(seg_id: IntArray, t: FloatArray) -> FloatArray:
        return gap_widths(search, seg_id, np.ascontiguousarray(t)) / GAP_FACTOR

    counts = np.maximum(np.ceil(2.0 * length / size).astype(np.int64), 1)
    if 2 * int(counts.sum()) > MAX_GAP_SAMPLES:  # refused before the arrays are made
        raise LimitExceeded(
            f"the boundary is {float(length.sum()) / size:,.0f} times the size long: its gaps "
            f"need more than {MAX_GAP_SAMPLES} boundary samples; use a larger size",
            limit=MAX_GAP_SAMPLES,
            estimate=2 * int(counts.sum()),
        )
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
    _check_resolution(region, max(size, size_min), None)
    a, b, prev, _ = ring_segments(region)
    vxy, vh = _vertex_features(a, b, prev, size)
    x0, y0, _, _ = region.bounds
    vertex_field = SizeField(build_tree(size, slope, 0.0, (x0, y0), vxy, vxy, vh, vh))
    progress("sizing", 0.2)
    if should_stop():
        raise Cancelled("stopped while sizing")
    ga, gb, g0, g1, samples = _gap_features(region, vertex_field, should_stop)
    progress("sizing", 0.8)
    # Refinements are segment features too (lines, polygon edges and chords), each at its rate.
    ra, rb, rh, rslope = refinement_features(params.refinements, params.growth)
    if len(g0) == 0 and len(rh) == 0 and size_min == 0.0:
        progress("sizing", 1.0)
        return _resolved(region, SizeField(vertex_field.tree, samples))  # the same features
    fa, fb = np.concatenate([vxy, ga, ra]), np.concatenate([vxy, gb, rb])
    ha = np.maximum(np.concatenate([vh, g0, rh]), size_min)
    hb = np.maximum(np.concatenate([vh, g1, rh]), size_min)
    slopes = np.concatenate([np.full(len(vh) + len(g0), slope), rslope])
    keep = np.minimum(ha, hb) < size
    tree = build_tree(
        size, slope, size_min, (x0, y0), fa[keep], fb[keep], ha[keep], hb[keep], slopes[keep]
    )
    progress("sizing", 1.0)
    return _resolved(region, SizeField(tree, samples))


def _resolved(region: Region, field: SizeField) -> SizeField:
    """``field``, once its smallest size is known to be resolved (:func:`_check_resolution`)."""
    h = field.feature_h
    at = field.tree.fa[int(np.argmin(h))] if h.size else None
    _check_resolution(region, field.smallest, at)
    return field


def _check_resolution(region: Region, size: float, at: FloatArray | None) -> None:
    """Raise :class:`LimitExceeded` when edges of ``size`` (asked for near ``at``, when given)
    span fewer than :data:`RESOLUTION_STEPS` representable steps of the region's largest
    coordinate: such a mesh cannot be represented (a square 1e-6 wide at 1e9 meshed at 1e-7
    failed on coincident points)."""
    far = float(np.abs(np.asarray(region.bounds)).max())
    step = float(np.spacing(far))
    if size >= RESOLUTION_STEPS * step:
        return
    near = "" if at is None else f" near ({at[0]:.9g}, {at[1]:.9g})"
    raise LimitExceeded(
        f"the mesh needs edges of {size:.3g}{near}, but coordinates as large as {far:.3g} are "
        f"resolved only to {step:.3g} (a mesh needs edges of at least {RESOLUTION_STEPS} such "
        "steps): move the region nearer the origin (a projected CRS whose numbers are smaller) "
        "or use a larger size",
        limit=RESOLUTION_STEPS,
        estimate=int(size / step),
    )
