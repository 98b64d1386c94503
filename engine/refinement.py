"""Refinements: ask for size ``s`` on and near a geometry, growing away from it at its own rate
(the job's ``growth`` unless the refinement gives one).

A refinement becomes features of the size field (:mod:`engine.sizing`): points sampled on the
geometry every ``s / 2`` (on lines and polygon edges) and on an ``s / 2`` grid inside polygons,
each asking for ``s`` and growing at the refinement's rate. The field is the lower envelope of
their cones and the region's own, so refinements combine with the region's sizing (and with
each other) by the minimum; between samples the envelope is within ``1 + (growth - 1) / 4`` of
``s``.

>>> r = Refinement({"type": "LineString", "coordinates": [[0, 0], [1, 0]]}, size=0.25, growth=1.1)
>>> xy, h, slope = refinement_features([r], growth=1.2)
>>> xy[:, 0].tolist(), set(h.tolist()), set(np.round(slope, 6).tolist())
([0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0], {0.25}, {0.1})
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

#: Samples per size along lines and across polygons (2: the envelope stays within 5% of s).
_SAMPLES_PER_SIZE = 2.0
#: Refinement samples beyond this are refused: the mesh would be far larger anyway.
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


def _samples(geom: shapely.Geometry, step: float) -> FloatArray:
    """Points on ``geom`` no further than ``step`` apart, and a ``step`` grid inside its areas."""
    pts = [shapely.get_coordinates(geom)]
    if geom.length > 0:  # a zero-length line is its point (GEOS cannot segmentize it)
        lines = shapely.segmentize(geom.boundary if geom.area > 0 else geom, step)
        pts.append(shapely.get_coordinates(lines))
    if geom.area > 0:
        x0, y0, x1, y1 = geom.bounds
        nx, ny = math.ceil((x1 - x0) / step) + 1, math.ceil((y1 - y0) / step) + 1
        if nx * ny > MAX_SAMPLES:
            raise LimitExceeded(
                f"a refinement polygon needs {nx * ny} samples at size {step * 2:g}",
                limit=MAX_SAMPLES,
                estimate=nx * ny,
            )
        gx, gy = np.meshgrid(x0 + step * np.arange(nx), y0 + step * np.arange(ny))
        inside = shapely.contains_xy(geom, gx.ravel(), gy.ravel())
        pts.append(np.c_[gx.ravel()[inside], gy.ravel()[inside]])
    return np.unique(np.concatenate(pts), axis=0)


def refinement_features(
    refinements: Sequence[Refinement], growth: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Feature points, the size each asks for and the slope (``growth - 1``) each grows at
    (``growth``: the job's, for refinements without their own), for
    :func:`engine.sizing.build_size_field`."""
    xy: list[FloatArray] = [np.empty((0, 2))]
    h: list[FloatArray] = [np.empty(0)]
    slope: list[FloatArray] = [np.empty(0)]
    for r in refinements:
        pts = _samples(r.shape(), r.size / _SAMPLES_PER_SIZE)
        xy.append(pts)
        h.append(np.full(len(pts), float(r.size)))
        slope.append(np.full(len(pts), (r.growth or growth) - 1.0))
    return np.concatenate(xy), np.concatenate(h), np.concatenate(slope)
