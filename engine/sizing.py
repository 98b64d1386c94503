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

import numba as nb
import numpy as np
import shapely
from numpy.typing import NDArray

from .boundary import Region
from .params import SizingParams
from .refinement import refinement_features

__all__ = [
    "GAP_FACTOR",
    "SizeField",
    "SizeTuple",
    "build_size_field",
    "estimate_triangles",
    "size_at",
    "size_field_at",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
#: The size field as numba kernels take it (see :meth:`SizeField.as_tuple`).
SizeTuple = tuple[
    float, float, float, FloatArray, FloatArray, float, float, float, int, int, IntArray, IntArray
]

#: Size asked for by a narrow gap, as a fraction of its width (two rows of triangles across).
GAP_FACTOR = 0.6
#: Cosine of the widest angle between a boundary point's inward normal and the direction to the
#: boundary it faces for the two to count as a gap (60 degrees: sharper corners count as gaps).
_FACING_COS = 0.5
_SHARP_CORNER_DEG = 60.0
_MAX_GRID_CELLS = 1 << 21
_MAX_GAP_SAMPLES = 4_000_000
#: Triangles per unit area of an equilateral mesh with edge h are 1 / (EQUILATERAL_AREA * h^2).
EQUILATERAL_AREA = math.sqrt(3.0) / 4.0


@dataclass(frozen=True)
class SizeField:
    """A size function; call it with an ``(k, 2)`` array of points.

    >>> from engine.boundary import make_region
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> field = build_size_field(square, SizingParams(size=0.1))
    >>> field(np.array([[0.5, 0.5]])).tolist()
    [0.1]
    """

    size: float  #: target size away from features (already clamped)
    slope: float  #: growth - 1
    size_min: float  #: lower clamp (0 when none)
    feature_xy: FloatArray  #: (f, 2) feature points
    feature_h: FloatArray  #: (f,) size each feature asks for
    origin: FloatArray  #: (2,) lower-left corner of the lookup grid
    cell: float  #: lookup grid spacing
    shape: tuple[int, int]  #: lookup grid cells (nx, ny)
    cell_start: IntArray  #: CSR offsets into cell_items, one per cell plus one
    cell_items: IntArray  #: feature indices whose cone can matter in each cell

    def __call__(self, xy: FloatArray) -> FloatArray:
        pts = np.ascontiguousarray(xy, dtype=np.float64).reshape(-1, 2)
        return _evaluate(
            pts,
            self.size,
            self.slope,
            self.size_min,
            self.feature_xy,
            self.feature_h,
            self.origin[0],
            self.origin[1],
            self.cell,
            self.shape[0],
            self.shape[1],
            self.cell_start,
            self.cell_items,
        )

    @property
    def smallest(self) -> float:
        """Smallest size the field asks for anywhere."""
        h = float(self.feature_h.min()) if self.feature_h.size else self.size
        return max(min(h, self.size), self.size_min)

    def as_tuple(
        self,
    ) -> tuple[
        float,
        float,
        float,
        FloatArray,
        FloatArray,
        float,
        float,
        float,
        int,
        int,
        IntArray,
        IntArray,
    ]:
        """The arrays and scalars that numba kernels take (see :func:`size_at`)."""
        return (
            self.size,
            self.slope,
            self.size_min,
            self.feature_xy,
            self.feature_h,
            float(self.origin[0]),
            float(self.origin[1]),
            self.cell,
            self.shape[0],
            self.shape[1],
            self.cell_start,
            self.cell_items,
        )


@nb.njit(cache=True, nogil=True)
def size_at(
    x: float,
    y: float,
    size: float,
    slope: float,
    size_min: float,
    fxy: FloatArray,
    fh: FloatArray,
    ox: float,
    oy: float,
    cell: float,
    nx: int,
    ny: int,
    start: IntArray,
    items: IntArray,
) -> float:  # pragma: no cover - compiled
    """The size field at one point (numba; arguments as :meth:`SizeField.as_tuple`)."""
    h = size
    if nx > 0:
        i = min(max(int((x - ox) / cell), 0), nx - 1)
        j = min(max(int((y - oy) / cell), 0), ny - 1)
        c = j * nx + i
        for k in range(start[c], start[c + 1]):
            f = items[k]
            d = math.sqrt((x - fxy[f, 0]) ** 2 + (y - fxy[f, 1]) ** 2)
            v = fh[f] + slope * d
            if v < h:
                h = v
    return max(h, size_min)


@nb.njit(cache=True, inline="always")
def size_field_at(sf: SizeTuple, x: float, y: float) -> float:
    """The size field at one point, from :meth:`SizeField.as_tuple` (numba)."""
    return size_at(
        x, y, sf[0], sf[1], sf[2], sf[3], sf[4], sf[5], sf[6], sf[7], sf[8], sf[9], sf[10], sf[11]
    )


@nb.njit(cache=True, nogil=True)
def _evaluate(
    pts: FloatArray,
    size: float,
    slope: float,
    size_min: float,
    fxy: FloatArray,
    fh: FloatArray,
    ox: float,
    oy: float,
    cell: float,
    nx: int,
    ny: int,
    start: IntArray,
    items: IntArray,
) -> FloatArray:  # pragma: no cover - compiled
    out = np.empty(pts.shape[0])
    for p in range(pts.shape[0]):
        out[p] = size_at(
            pts[p, 0], pts[p, 1], size, slope, size_min, fxy, fh, ox, oy, cell, nx, ny, start, items
        )
    return out


@nb.njit(cache=True)
def _splat(
    fxy: FloatArray,
    fh: FloatArray,
    size: float,
    slope: float,
    ox: float,
    oy: float,
    cell: float,
    nx: int,
    ny: int,
) -> tuple[IntArray, IntArray]:  # pragma: no cover - compiled
    """Put each feature into every grid cell its cone reaches below ``size``."""
    nf = fxy.shape[0]
    counts = np.zeros(nx * ny + 1, dtype=np.int64)
    for pass_ in range(2):
        if pass_ == 1:
            for c in range(nx * ny):
                counts[c + 1] += counts[c]
            items = np.empty(counts[nx * ny], dtype=np.int64)
            fill = counts[:-1].copy()
        for f in range(nf):
            reach = (size - fh[f]) / slope
            i0 = max(int((fxy[f, 0] - reach - ox) / cell), 0)
            i1 = min(int((fxy[f, 0] + reach - ox) / cell), nx - 1)
            j0 = max(int((fxy[f, 1] - reach - oy) / cell), 0)
            j1 = min(int((fxy[f, 1] + reach - oy) / cell), ny - 1)
            for j in range(j0, j1 + 1):
                for i in range(i0, i1 + 1):
                    # Skip cells that the cone cannot reach: distance from f to the cell box.
                    dx = max(ox + i * cell - fxy[f, 0], 0.0, fxy[f, 0] - (ox + (i + 1) * cell))
                    dy = max(oy + j * cell - fxy[f, 1], 0.0, fxy[f, 1] - (oy + (j + 1) * cell))
                    if dx * dx + dy * dy > reach * reach:
                        continue
                    c = j * nx + i
                    if pass_ == 0:
                        counts[c + 1] += 1
                    else:
                        items[fill[c]] = f
                        fill[c] += 1
    start = counts
    return start, items


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
    reach: float,
) -> FloatArray:
    """Size each sample asks for because it faces another part of the boundary within reach."""
    out = np.full(len(samples), np.inf)
    chunk = 200_000
    for lo in range(0, len(samples), chunk):
        sl = slice(lo, lo + chunk)
        s_idx, g_idx = tree.query(shapely.points(samples[sl]), predicate="dwithin", distance=reach)
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


def _gap_features(region: Region, size: float) -> tuple[FloatArray, FloatArray]:
    """Features from narrow gaps, sampled by bisecting each segment where a gap asks for finer
    spacing than the samples have, so a pinch costs samples only near the pinch."""
    a, b, prev, nxt = _ring_segments(region)
    seg = b - a
    length = np.hypot(seg[:, 0], seg[:, 1])
    normal = np.stack([-seg[:, 1], seg[:, 0]], axis=1) / np.maximum(length, 1e-300)[:, None]
    tree = shapely.STRtree(shapely.linestrings(np.stack([a, b], axis=1)))
    reach = size / GAP_FACTOR
    # Intervals (segment, t0, t1) of parameter space, first no longer than size / 2.
    counts = np.maximum(np.ceil(2.0 * length / size).astype(np.int64), 1)
    seg_id = np.repeat(np.arange(len(a)), counts)
    first = np.cumsum(counts) - counts
    k = np.arange(len(seg_id)) - np.repeat(first, counts)
    t0 = k / counts[seg_id]
    t1 = (k + 1) / counts[seg_id]
    found_xy: list[FloatArray] = []
    found_h: list[FloatArray] = []
    total = 0
    for _ in range(64):
        if len(seg_id) == 0 or total > _MAX_GAP_SAMPLES:
            break
        mid = 0.5 * (t0 + t1)
        pts = a[seg_id] + mid[:, None] * seg[seg_id]
        h = _gap_sizes(pts, normal[seg_id], seg_id, a, b, prev, nxt, tree, reach)
        total += len(pts)
        hit = np.isfinite(h)
        found_xy.append(pts[hit])
        found_h.append(h[hit])
        # Bisect intervals longer than the size their sample asks for.
        fine = (t1 - t0) * length[seg_id] > h
        seg_id, t0, t1, mid = seg_id[fine], t0[fine], t1[fine], mid[fine]
        seg_id = np.concatenate([seg_id, seg_id])
        t0, t1 = np.concatenate([t0, mid]), np.concatenate([mid, t1])
    xy = np.concatenate(found_xy) if found_xy else np.empty((0, 2))
    hh = np.concatenate(found_h) if found_h else np.empty(0)
    return xy, hh


def _thin(xy: FloatArray, h: FloatArray, slope: float) -> tuple[FloatArray, FloatArray]:
    """Drop features whose cone is (within 5%) under another's: the field changes by < 5%."""
    if len(h) < 2:
        return xy, h
    order = np.argsort(h, kind="stable")
    xy, h = xy[order], h[order]
    # Bucket by a grid of the smallest size: a feature is dropped when an earlier (smaller) one in
    # its bucket already covers it.
    cell = max(float(h[0]), 1e-300)
    key = np.floor(xy / cell).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    keep = np.zeros(len(h), dtype=bool)
    keep[first] = True
    rep = np.unique(key, axis=0, return_inverse=True)[1].ravel()
    head = np.full(rep.max() + 1, -1)
    head[rep[first]] = first
    covered = h[head[rep]] + slope * np.hypot(*(xy - xy[head[rep]]).T) <= 1.05 * h
    keep |= ~covered
    return xy[keep], h[keep]


def build_size_field(region: Region, params: SizingParams) -> SizeField:
    """The graded size field of ``region`` for ``params``."""
    size = params.size
    if params.size_max is not None:
        size = min(size, params.size_max)
    size_min = params.size_min or 0.0
    slope = params.growth - 1.0
    a, b, prev, _ = _ring_segments(region)
    vxy, vh = _vertex_features(a, b, prev, size)
    gxy, gh = _gap_features(region, size)
    rxy, rh = refinement_features(params.refinements)  # refinements are features too
    fxy = np.concatenate([vxy, gxy, rxy])
    fh = np.maximum(np.concatenate([vh, gh, rh]), size_min)
    keep = fh < size
    fxy, fh = _thin(fxy[keep], fh[keep], slope)
    x0, y0, x1, y1 = region.bounds
    if len(fh) == 0:
        return SizeField(
            size, slope, size_min, np.empty((0, 2)), np.empty(0), np.array([x0, y0]), 1.0,
            (0, 0), np.zeros(1, dtype=np.int64), np.empty(0, dtype=np.int64),
        )  # fmt: skip
    span = max(x1 - x0, y1 - y0, 1e-300)
    cell = max(size, span / math.sqrt(_MAX_GRID_CELLS))
    nx = max(math.ceil((x1 - x0) / cell), 1)
    ny = max(math.ceil((y1 - y0) / cell), 1)
    start, items = _splat(
        np.ascontiguousarray(fxy), np.ascontiguousarray(fh), size, slope, x0, y0, cell, nx, ny
    )
    return SizeField(
        size, slope, size_min, np.ascontiguousarray(fxy), np.ascontiguousarray(fh),
        np.array([x0, y0]), cell, (nx, ny), start, items,
    )  # fmt: skip


def estimate_triangles(region: Region, field: SizeField, max_cells: int = 1 << 20) -> int:
    """Expected triangle count: the integral of ``1 / (sqrt(3)/4 h^2)`` over the region.

    Integrated on an adaptive quadtree whose cells are split while they are larger than the
    size at their centre, so small features are counted too.

    >>> from engine.boundary import make_region
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> estimate_triangles(square, build_size_field(square, SizingParams(size=0.1)))
    231
    """
    shape = region.to_shapely()
    shapely.prepare(shape)
    x0, y0, x1, y1 = region.bounds
    cell = field.size
    nx = max(math.ceil((x1 - x0) / cell), 1)
    ny = max(math.ceil((y1 - y0) / cell), 1)
    while nx * ny > max_cells:
        cell *= 2.0
        nx, ny = max(math.ceil((x1 - x0) / cell), 1), max(math.ceil((y1 - y0) / cell), 1)
    gx, gy = np.meshgrid(x0 + cell * (np.arange(nx) + 0.5), y0 + cell * (np.arange(ny) + 0.5))
    centres = np.c_[gx.ravel(), gy.ravel()]
    total = 0.0
    while len(centres):
        h = field(centres)
        split = h < 0.5 * cell
        if len(centres) + 3 * int(split.sum()) > max_cells:
            split[:] = False  # out of cells: count the rest at their centre size
        keep = ~split
        # A leaf counts its area inside the region, sampled at its centre.
        inside = shapely.contains_xy(shape, centres[keep, 0], centres[keep, 1])
        total += float(np.sum(cell * cell / (EQUILATERAL_AREA * h[keep][inside] ** 2)))
        quarter = 0.25 * cell
        c = centres[split]
        centres = np.concatenate(
            [c + np.array([dx, dy]) * quarter for dx in (-1, 1) for dy in (-1, 1)]
        ) if len(c) else np.empty((0, 2))  # fmt: skip
        cell *= 0.5
    return round(total)
