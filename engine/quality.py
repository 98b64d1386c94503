"""Per-triangle quality metrics and stage summaries.

Every metric is vectorised over all triangles and registered by name in :data:`METRICS`; the
registry drives the per-triangle fields of the mesh document, the stage summaries and the
colourings of pictures, so a metric added here appears in all three.

>>> right = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
>>> [round(float(m(right, np.array([[0, 1, 2]]))[0]), 4) for m in METRICS.values()]
[0.866, 0.8284, 45.0, 90.0]
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property

import numba
import numpy as np
from numpy.typing import NDArray

from .mesh import Mesh

__all__ = [
    "METRICS",
    "Metric",
    "TriangleGeometry",
    "TriangleQuality",
    "register_metric",
    "shape_quality_xy",
    "summarize",
    "triangle_quality",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_SQRT3 = float(np.sqrt(3.0))


@numba.njit(cache=True, inline="always")
def shape_quality_xy(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    """:func:`shape_quality` of one triangle given by its corners, for compiled kernels."""
    area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    s = (bx - ax) ** 2 + (by - ay) ** 2 + (cx - bx) ** 2 + (cy - by) ** 2
    s += (ax - cx) ** 2 + (ay - cy) ** 2
    return 2.0 * _SQRT3 * area2 / s if s > 0.0 else 0.0


@numba.njit(cache=True)
def _sides_and_area(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Rows: squared sides opposite corners 0, 1, 2 and the signed area of each triangle, in
    one pass (numpy's gathers and axis sums cost several times more). Every figure is rounded
    as the plain numpy statement rounds it: ``((c - b) ** 2).sum(axis=1)`` adds its two terms
    to a zero first, which matters only for the sign of a zero."""
    m = triangles.shape[0]
    out = np.empty((4, m))
    for i in range(m):
        ax, ay = points[triangles[i, 0], 0], points[triangles[i, 0], 1]
        bx, by = points[triangles[i, 1], 0], points[triangles[i, 1], 1]
        cx, cy = points[triangles[i, 2], 0], points[triangles[i, 2], 1]
        out[0, i] = (cx - bx) * (cx - bx) + (0.0 + (cy - by) * (cy - by))
        out[1, i] = (ax - cx) * (ax - cx) + (0.0 + (ay - cy) * (ay - cy))
        out[2, i] = (bx - ax) * (bx - ax) + (0.0 + (by - ay) * (by - ay))
        out[3, i] = 0.5 * ((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))
    return out


@numba.njit(cache=True)
def _cross_dot(points: FloatArray, triangles: IntArray) -> tuple[FloatArray, FloatArray]:
    """Per corner k (row) and triangle: |u x v| and u . v of the sides u, v leaving the
    corner, rounded as numpy rounds them (see :func:`_sides_and_area`)."""
    m = triangles.shape[0]
    cross = np.empty((3, m))
    dot = np.empty((3, m))
    for i in range(m):
        for k in range(3):
            a, b = triangles[i, k], triangles[i, (k + 1) % 3]
            c = triangles[i, (k + 2) % 3]
            ux, uy = points[b, 0] - points[a, 0], points[b, 1] - points[a, 1]
            vx, vy = points[c, 0] - points[a, 0], points[c, 1] - points[a, 1]
            cross[k, i] = math.fabs(ux * vy - uy * vx)
            dot[k, i] = ux * vx + (0.0 + uy * vy)
    return cross, dot


class TriangleGeometry:
    """Side lengths, areas and angles of triangles, each computed once when first asked for.

    Metrics that share a quantity (the angles, the squared sides) read it from here. The
    built-in quantities come from compiled kernels, bit for bit what the plain numpy
    statements give (the tests hold them to it).
    """

    def __init__(self, points: FloatArray, triangles: IntArray) -> None:
        self.points = points
        self.triangles = triangles

    @cached_property
    def _arrays(self) -> tuple[FloatArray, IntArray]:
        points = np.ascontiguousarray(self.points, dtype=np.float64)
        return points, np.ascontiguousarray(self.triangles, dtype=np.int64)

    @cached_property
    def _sides_and_area(self) -> FloatArray:
        return _sides_and_area(*self._arrays)

    @cached_property
    def corners(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Coordinates (m, 2) of corners 0, 1, 2 (for metrics registered elsewhere)."""
        a, b, c = (self.points[self.triangles[:, k]] for k in range(3))
        return a, b, c

    @cached_property
    def squared_sides(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Squared lengths of the sides opposite corners 0, 1, 2."""
        s = self._sides_and_area
        return s[0], s[1], s[2]

    @cached_property
    def area(self) -> FloatArray:
        """Signed area: negative for triangles listed clockwise."""
        area: FloatArray = self._sides_and_area[3]
        return area

    @cached_property
    def angles(self) -> FloatArray:
        """Interior angles (m, 3) in degrees at corners 0, 1, 2."""
        cross, dot = _cross_dot(*self._arrays)
        out = np.empty((cross.shape[1], 3))
        for k in range(3):  # numpy's arctan2 (vectorised, and what the figures always used)
            out[:, k] = np.degrees(np.arctan2(cross[k], dot[k]))
        return out


def _shape_quality(g: TriangleGeometry) -> FloatArray:
    s0, s1, s2 = g.squared_sides
    return 4.0 * _SQRT3 * g.area / np.maximum(s0 + s1 + s2, 1e-300)


def _radius_ratio(g: TriangleGeometry) -> FloatArray:
    s0, s1, s2 = g.squared_sides
    l0, l1, l2 = np.sqrt(s0), np.sqrt(s1), np.sqrt(s2)
    area = g.area
    denom = np.maximum(l0 * l1 * l2 * (l0 + l1 + l2), 1e-300)
    return np.sign(area) * 16.0 * area * area / denom


def shape_quality(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Normalised shape measure ``4*sqrt(3)*A / (l1^2 + l2^2 + l3^2)``: 1 equilateral, 0 flat.

    Negative for inverted triangles.

    >>> eq = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    >>> round(float(shape_quality(eq, np.array([[0, 1, 2]]))[0]), 12)
    1.0
    """
    return _shape_quality(TriangleGeometry(points, triangles))


def radius_ratio(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Gmsh's gamma, ``2r/R`` (inradius over circumradius): 1 equilateral, 0 flat.

    Uses ``2r/R = 16 A^2 / (l1 l2 l3 (l1 + l2 + l3))``; negative for inverted triangles.

    >>> right = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> round(float(radius_ratio(right, np.array([[0, 1, 2]]))[0]), 6)
    0.828427
    """
    return _radius_ratio(TriangleGeometry(points, triangles))


def corner_angles(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Interior angles (m, 3) in degrees at corners 0, 1, 2."""
    return TriangleGeometry(points, triangles).angles


def _row_min(values: FloatArray) -> FloatArray:
    """``values.min(axis=1)`` of an (m, 3) array, the same numbers 40 times faster."""
    return np.minimum(np.minimum(values[:, 0], values[:, 1]), values[:, 2])


def _row_max(values: FloatArray) -> FloatArray:
    """``values.max(axis=1)`` of an (m, 3) array (see :func:`_row_min`)."""
    return np.maximum(np.maximum(values[:, 0], values[:, 1]), values[:, 2])


def min_angle(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Smallest interior angle of each triangle, in degrees."""
    return _row_min(corner_angles(points, triangles))


def max_angle(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Largest interior angle of each triangle, in degrees."""
    return _row_max(corner_angles(points, triangles))


@dataclass(frozen=True)
class Metric:
    """A per-triangle quality figure: a field of the mesh document's ``cell_data``, a block of
    every stage summary and a colouring of pictures."""

    name: str
    compute: Callable[[TriangleGeometry], FloatArray] = field(repr=False)
    label: str  #: in words, with its unit (a colour bar's label)
    ideal: float  #: the value of an equilateral triangle
    worst: float  #: the value of a degenerate one
    unit: str = ""  #: "deg" for angles, "" for ratios

    def __call__(self, points: FloatArray, triangles: IntArray) -> FloatArray:
        """The figure of every triangle, shape ``(m,)``."""
        return self.compute(TriangleGeometry(points, triangles))


def register_metric(metric: Metric) -> Metric:
    """Add (or replace) a metric: the document, the summaries and the pictures then carry it."""
    METRICS[metric.name] = metric
    return metric


#: Per-triangle quality metrics by name, in the order documents and summaries list them.
METRICS: dict[str, Metric] = {}

register_metric(Metric("quality", _shape_quality, "triangle quality (1 = equilateral)", 1.0, 0.0))
register_metric(
    Metric("radius_ratio", _radius_ratio, "radius ratio 2r/R (1 = equilateral)", 1.0, 0.0)
)
register_metric(
    Metric(
        "min_angle",
        lambda g: _row_min(g.angles),
        "smallest angle of the triangle (degrees)",
        60.0,
        0.0,
        "deg",
    )
)
register_metric(
    Metric(
        "max_angle",
        lambda g: _row_max(g.angles),
        "largest angle of the triangle (degrees)",
        60.0,
        180.0,
        "deg",
    )
)


@dataclass(frozen=True)
class TriangleQuality:
    """Per-triangle figures of one mesh: every metric of :data:`METRICS`, and the signed area.

    >>> eq = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    >>> q = triangle_quality(Mesh(eq, np.array([[0, 1, 2]])))
    >>> list(q.values), round(float(q["min_angle"][0]), 6)
    (['quality', 'radius_ratio', 'min_angle', 'max_angle'], 60.0)
    """

    values: Mapping[str, FloatArray]  #: by metric name
    area: FloatArray  #: signed area (the inverted triangles are those at or below zero)

    def __getitem__(self, name: str) -> FloatArray:
        return self.values[name]

    @property
    def quality(self) -> FloatArray:
        """4*sqrt(3)*A / sum of squared sides."""
        return self.values["quality"]

    @property
    def radius_ratio(self) -> FloatArray:
        """2r/R."""
        return self.values["radius_ratio"]

    @property
    def min_angle(self) -> FloatArray:
        """Degrees."""
        return self.values["min_angle"]

    @property
    def max_angle(self) -> FloatArray:
        """Degrees."""
        return self.values["max_angle"]


def triangle_quality(mesh: Mesh) -> TriangleQuality:
    """Every metric of every triangle of ``mesh``."""
    g = TriangleGeometry(mesh.points, mesh.triangles)
    return TriangleQuality({name: m.compute(g) for name, m in METRICS.items()}, g.area)


def _stats(values: FloatArray) -> dict[str, float | None]:
    if values.size == 0:
        return {"min": None, "p5": None, "mean": None, "max": None}
    # The 5th percentile by linear interpolation (as numpy's default), from a partition.
    pos = 0.05 * (values.size - 1)
    lo = int(pos)
    hi = min(lo + 1, values.size - 1)
    part = np.partition(values, (lo, hi))
    p5 = part[lo] + (pos - lo) * (part[hi] - part[lo])
    return {
        "min": float(values.min()),
        "p5": float(p5),
        "mean": float(values.mean()),
        "max": float(values.max()),
    }


def summarize(q: TriangleQuality) -> dict[str, object]:
    """Summary of one stage: count; min, p5, mean, max of each metric (in the order of
    :data:`METRICS`); shares of poor triangles.

    >>> eq = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    >>> s = summarize(triangle_quality(Mesh(eq, np.array([[0, 1, 2]]))))
    >>> s["count"], round(s["quality"]["min"], 6), s["share_below_30deg"]
    (1, 1.0, 0.0)
    """
    n = int(q.area.size)
    return {
        "count": n,
        **{name: _stats(values) for name, values in q.values.items()},
        "share_below_30deg": float(np.mean(q.min_angle < 30.0)) if n else 0.0,
        "share_quality_ge_0.91": float(np.mean(q.quality >= 0.91)) if n else 0.0,
        "inverted": int(np.count_nonzero(q.area <= 0.0)),
    }
