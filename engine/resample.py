"""Resampling of digitised boundaries: drop vertices the size does not need.

A digitised boundary (survey lines, traced maps) has vertices far closer than the mesh size,
and the mesher keeps every input vertex (:mod:`engine.discretize`). :func:`resample_region`
first simplifies each ring to the local size: vertices at real corners stay, the rest are
thinned with Douglas-Peucker (shapely's ``simplify``) so that the new ring stays within
``tolerance`` of the input; the usual discretisation then splits it to the size field.

The local size used here is the smallest size asked for anywhere (``size`` within its clamps,
and each refinement's size): the field itself depends on the boundary, so it is built on the
resampled region afterwards.

>>> from engine.boundary import make_region
>>> from engine.params import SizingParams
>>> t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
>>> circle = make_region([(np.c_[10 * np.cos(t), 10 * np.sin(t)], [])])
>>> out = resample_region(circle, SizingParams(size=1.0, resample=True))
>>> out.region.n_vertices < 200, out.max_deviation <= 0.1
(True, True)
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np
import shapely
from numpy.typing import NDArray

from .boundary import Region, make_region
from .errors import InvalidBoundary
from .params import SizingParams

__all__ = [
    "CORNER_DEG",
    "DEFAULT_TOLERANCE",
    "Resampled",
    "corners",
    "resample_region",
    "resample_size",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: A vertex is a corner when the boundary turns by more than this (degrees) across a window
#: of the local size centred on it: digitising noise, far smaller than the size, does not.
CORNER_DEG = 25.0
#: Default tolerance, as a fraction of the local size.
DEFAULT_TOLERANCE = 0.1
#: Halvings of the tolerance tried when a simplified region is invalid or touches itself.
_RETRIES = 4


@dataclass(frozen=True)
class Resampled:
    """A resampled region and how far its boundary is from the input's."""

    region: Region
    max_deviation: float  #: largest distance from an input vertex to the resampled boundary
    tolerance: float  #: the tolerance that gave a valid region (0 when the input was kept)
    vertices_before: int
    vertices_after: int

    def summary(self) -> dict[str, float | int]:
        """The figures a result's ``summary["boundary"]`` carries."""
        return {
            "resampled": True,
            "max_deviation": self.max_deviation,
            "tolerance": self.tolerance,
            "vertices_before": self.vertices_before,
            "vertices_after": self.vertices_after,
        }


def resample_size(sizing: SizingParams) -> float:
    """The local size resampling works to: the smallest size asked for anywhere.

    >>> resample_size(SizingParams(size=2.0, size_max=1.5))
    1.5
    """
    h = sizing.size
    if sizing.size_max is not None:
        h = min(h, sizing.size_max)
    if sizing.size_min is not None:
        h = max(h, sizing.size_min)
    return min([h, *(r.size for r in sizing.refinements)])


def _arc(ring: FloatArray) -> tuple[FloatArray, float]:
    seg = np.hypot(*(np.roll(ring, -1, axis=0) - ring).T)
    return np.concatenate(([0.0], np.cumsum(seg)[:-1])), float(seg.sum())


def _at(ring: FloatArray, s_of: FloatArray, perimeter: float, s: FloatArray) -> FloatArray:
    """Points at arc lengths ``s`` (any real, taken around the closed ring)."""
    closed_s = np.append(s_of, perimeter)
    closed = np.vstack([ring, ring[:1]])
    s = np.mod(s, perimeter)
    return np.c_[np.interp(s, closed_s, closed[:, 0]), np.interp(s, closed_s, closed[:, 1])]


def corners(ring: FloatArray, window: float) -> IntArray:
    """Indices of the vertices of ``ring`` where it turns by more than :data:`CORNER_DEG`
    across ``window`` (centred on the vertex); of those within the window of each other, the
    sharpest.

    >>> corners(np.array([[0.0, 0], [1, 0], [2, 0], [2, 1], [2, 2], [0, 2]]), 0.5).tolist()
    [0, 2, 4, 5]
    """
    s_of, perimeter = _arc(ring)
    half = min(0.5 * window, perimeter / 8.0)
    back = _at(ring, s_of, perimeter, s_of - half)
    fwd = _at(ring, s_of, perimeter, s_of + half)
    d_in, d_out = ring - back, fwd - ring
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    turn = np.degrees(np.abs(np.arctan2(cross, (d_in * d_out).sum(axis=1))))
    sharp = turn > CORNER_DEG
    if not sharp.any():
        return np.empty(0, dtype=np.int64)
    # Of the vertices within the window of each other, the sharpest (the vertices next to a
    # corner see it inside their window too, turning less).
    closed_s = np.r_[s_of - perimeter, s_of, s_of + perimeter]
    turns = np.r_[turn, turn, turn]
    picked = []
    for i in np.flatnonzero(sharp):
        lo, hi = np.searchsorted(closed_s, [s_of[i] - half, s_of[i] + half], side="left")
        if turn[i] >= turns[lo : hi + 1].max():
            picked.append(i)
    return np.sort(np.asarray(picked, dtype=np.int64))


def _simplify_ring(ring: FloatArray, window: float, tolerance: float) -> FloatArray:
    """``ring`` thinned between its corners (kept) to within ``tolerance``."""
    anchors = corners(ring, window)
    if len(anchors) < 3:  # a smooth ring: anchor it at thirds of its length as well
        s_of, perimeter = _arc(ring)
        thirds = np.searchsorted(s_of, perimeter * np.arange(3) / 3.0)
        anchors = np.unique(np.r_[anchors, np.minimum(thirds, len(ring) - 1)])
    if len(anchors) >= len(ring):
        return ring
    bounds = np.r_[anchors, anchors[0] + len(ring)]
    doubled = np.vstack([ring, ring])
    pairs = pairwise(bounds)
    lines = np.array([shapely.LineString(doubled[a : b + 1]) for a, b in pairs])
    thinned = shapely.simplify(lines, tolerance, preserve_topology=False)
    pieces = shapely.get_coordinates(thinned)
    counts = shapely.get_num_coordinates(thinned)
    last = np.cumsum(counts) - 1  # each piece's end is the next one's start
    out = np.delete(pieces, last, axis=0)
    return ring if len(out) < 3 else out


def _deviation(before: FloatArray, after: FloatArray) -> float:
    """Largest distance from a vertex of ``before`` to the closed ring ``after`` (the
    vertices of ``after`` are vertices of ``before``, so the other direction is 0)."""
    return float(shapely.distance(shapely.points(before), shapely.linearrings(after)).max())


def resample_region(region: Region, sizing: SizingParams) -> Resampled:
    """``region`` with each ring re-discretised to the local size (:func:`resample_size`):
    corners kept, every input vertex within the tolerance (``sizing.resample_tolerance``, by
    default :data:`DEFAULT_TOLERANCE` of the size) of the new boundary. When the simplified
    region is not valid (rings crossing or touching), the tolerance is halved and tried again;
    after :data:`_RETRIES` halvings the input is kept."""
    h = resample_size(sizing)
    tolerance = sizing.resample_tolerance
    tolerance = DEFAULT_TOLERANCE * h if tolerance is None else tolerance
    before = region.n_vertices
    for _ in range(_RETRIES + 1):
        parts = [[_simplify_ring(r, h, tolerance) for r in part.rings] for part in region.parts]
        try:
            simplified = make_region([(rings[0], rings[1:]) for rings in parts])
        except InvalidBoundary:
            tolerance *= 0.5
            continue
        deviation = max(
            _deviation(a, b)
            for part, rings in zip(region.parts, parts, strict=True)
            for a, b in zip(part.rings, rings, strict=True)
        )
        return Resampled(simplified, deviation, tolerance, before, simplified.n_vertices)
    return Resampled(region, 0.0, 0.0, before, before)
