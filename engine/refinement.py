"""Refinements: ask for size ``s`` on and near a geometry, growing away from it at its own rate
(the job's ``growth`` unless the refinement gives one).

A refinement becomes features of the size field (:mod:`engine.sizing`): the segments of its
lines and polygon edges (a point is a segment of no length), each asking for ``s`` all along it,
and horizontal chords ``s / 2`` apart across polygons; each grows at the refinement's rate. The
field is the lower envelope of their cones and the region's own, so refinements combine with the
region's sizing (and with each other) by the minimum; inside a polygon, between chords, the
envelope is within ``1 + (growth - 1) / 4`` of ``s``. A line costs a feature per segment and a
polygon one per chord, whatever the size: sampled as points every ``s / 2``, a line at
``s = 1e-7`` made 80 million features and a 0.8-wide square at ``8.5e-4`` 3.5 million (10 s and
1 GB) before the triangle estimate could refuse them.

>>> r = Refinement({"type": "LineString", "coordinates": [[0, 0], [1, 0], [1, 1]]}, 0.25, 1.1)
>>> start, end, h, slope = refinement_features([r], growth=1.2)
>>> start.tolist(), end.tolist(), set(h.tolist()), set(np.round(slope, 6).tolist())
([[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [1.0, 1.0]], {0.25}, {0.1})
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
import shapely.geometry
from numpy.typing import NDArray

from .errors import EngineError, LimitExceeded

__all__ = ["InvalidRefinement", "Refinement", "refinement_features"]

FloatArray = NDArray[np.float64]

#: Chords per size across polygons (2: the envelope stays within 5% of s).
_SAMPLES_PER_SIZE = 2.0
#: Chords across a refinement polygon beyond this are refused: the mesh would be far larger
#: anyway.
MAX_SAMPLES = 4_000_000


class InvalidRefinement(EngineError, ValueError):
    """A refinement whose geometry or size cannot be used."""


@dataclass(frozen=True)
class Refinement:
    """Size ``size`` on ``geometry`` (a GeoJSON geometry mapping: Point, LineString, Polygon,
    their Multi* forms or a GeometryCollection), growing away at ``growth`` (``None``: the
    job's)."""

    geometry: Mapping[str, Any]
    size: float
    growth: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.size) and self.size > 0):
            raise InvalidRefinement(
                f"a refinement's size must be a positive number, not {self.size}"
            )
        if self.growth is not None and not (math.isfinite(self.growth) and self.growth > 1.0):
            raise InvalidRefinement(
                f"a refinement's growth must be a number greater than 1, not {self.growth}"
            )
        self.shape()

    def shape(self) -> shapely.Geometry:
        """The geometry as shapely's; :class:`InvalidRefinement` when it is not GeoJSON."""
        try:
            geom = shapely.geometry.shape(self.geometry)
        except (AttributeError, KeyError, TypeError, ValueError, shapely.errors.ShapelyError) as e:
            raise InvalidRefinement(
                f"a refinement's geometry is not a GeoJSON geometry: {e}"
            ) from None
        if geom.is_empty or not np.isfinite(shapely.get_coordinates(geom)).all():
            raise InvalidRefinement("a refinement's geometry is empty or not finite")
        return geom


def _linework(geom: shapely.Geometry) -> tuple[FloatArray, FloatArray]:
    """Starts and ends of the segments of ``geom``'s lines and polygon rings; a point (or a line
    of no length) is a segment from itself to itself."""
    if isinstance(geom, shapely.geometry.base.BaseMultipartGeometry):
        parts = [_linework(g) for g in geom.geoms] or [(np.empty((0, 2)), np.empty((0, 2)))]
        return np.concatenate([a for a, _ in parts]), np.concatenate([b for _, b in parts])
    if isinstance(geom, shapely.Polygon):
        rings = [_linework(r) for r in (geom.exterior, *geom.interiors)]
        return np.concatenate([a for a, _ in rings]), np.concatenate([b for _, b in rings])
    xy = shapely.get_coordinates(geom)
    if len(xy) < 2:
        return xy, xy
    return xy[:-1], xy[1:]


def _chords(geom: shapely.Geometry, step: float) -> tuple[FloatArray, FloatArray]:
    """Starts and ends of horizontal chords of ``geom``'s areas, ``step`` apart (none for points
    and lines): with the edges, every point inside is within ``step / 2`` of a feature."""
    if geom.area <= 0:
        return np.empty((0, 2)), np.empty((0, 2))
    x0, y0, x1, y1 = geom.bounds
    n = math.ceil((y1 - y0) / step) + 1
    if n > MAX_SAMPLES:
        raise LimitExceeded(
            f"a refinement polygon needs {n} chords at size {step * 2:g}",
            limit=MAX_SAMPLES,
            estimate=n,
        )
    y = y0 + step * np.arange(n)
    pad = x1 - x0  # the lines reach past the polygon at any scale
    ends = np.stack([np.c_[np.full(n, x0 - pad), y], np.c_[np.full(n, x1 + pad), y]], axis=1)
    pieces = shapely.get_parts(shapely.intersection(shapely.linestrings(ends), geom))
    xy, index = shapely.get_coordinates(pieces, return_index=True)
    same = index[1:] == index[:-1]  # consecutive points of one piece (a lone point: a tangent)
    return xy[:-1][same], xy[1:][same]


def refinement_features(
    refinements: Sequence[Refinement], growth: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Feature segments (starts and ends; a point is a segment of no length), the size each asks
    for and the slope (``growth - 1``) each grows at (``growth``: the job's, for refinements
    without their own), for :func:`engine.sizing.build_size_field`."""
    start: list[FloatArray] = [np.empty((0, 2))]
    end: list[FloatArray] = [np.empty((0, 2))]
    h: list[FloatArray] = [np.empty(0)]
    slope: list[FloatArray] = [np.empty(0)]
    for r in refinements:
        geom = r.shape()
        a, b = _linework(geom)
        ca, cb = _chords(geom, r.size / _SAMPLES_PER_SIZE)
        start += [a, ca]
        end += [b, cb]
        count = len(a) + len(ca)
        h.append(np.full(count, float(r.size)))
        slope.append(np.full(count, (r.growth or growth) - 1.0))
    return np.concatenate(start), np.concatenate(end), np.concatenate(h), np.concatenate(slope)
