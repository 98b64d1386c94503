"""Per-triangle quality metrics and stage summaries.

Every metric is vectorised over all triangles and registered by name in :data:`METRICS`; the
registry drives the per-triangle fields of the mesh document, the stage summaries and the
colourings of pictures, so a metric added here appears in all three.

>>> right = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
>>> [round(float(m(right, np.array([[0, 1, 2]]))[0]), 4) for m in METRICS.values()]
[0.866, 0.8284, 45.0, 90.0]
"""

from __future__ import annotations

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


class TriangleGeometry:
    """Side lengths, areas and angles of triangles, each computed once when first asked for.

    Metrics that share a quantity (the angles, the squared sides) read it from here.
    """

    def __init__(self, points: FloatArray, triangles: IntArray) -> None:
        self.points = points
        self.triangles = triangles

    @cached_property
    def corners(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Coordinates (m, 2) of corners 0, 1, 2: gathered once for every quantity below
        (gathering is a good part of their cost)."""
        a, b, c = (self.points[self.triangles[:, k]] for k in range(3))
        return a, b, c

    @cached_property
    def squared_sides(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Squared lengths of the sides opposite corners 0, 1, 2."""
        a, b, c = self.corners
        return (
            ((c - b) ** 2).sum(axis=1),
            ((a - c) ** 2).sum(axis=1),
            ((b - a) ** 2).sum(axis=1),
        )

    @cached_property
    def area(self) -> FloatArray:
        """Signed area: negative for triangles listed clockwise."""
        a, b, c = self.corners
        return 0.5 * (
            (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        )

    @cached_property
    def angles(self) -> FloatArray:
        """Interior angles (m, 3) in degrees at corners 0, 1, 2."""
        return _angles_of(self.corners)


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


def _angles_of(corners: tuple[FloatArray, FloatArray, FloatArray]) -> FloatArray:
    out = np.empty((len(corners[0]), 3))
    for k in range(3):
        a = corners[k]
        u = corners[(k + 1) % 3] - a
        v = corners[(k + 2) % 3] - a
        cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
        out[:, k] = np.degrees(np.arctan2(np.abs(cross), (u * v).sum(axis=1)))
    return out


def min_angle(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Smallest interior angle of each triangle, in degrees."""
    return corner_angles(points, triangles).min(axis=1)


def max_angle(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Largest interior angle of each triangle, in degrees."""
    return corner_angles(points, triangles).max(axis=1)


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
        lambda g: g.angles.min(axis=1),
        "smallest angle of the triangle (degrees)",
        60.0,
        0.0,
        "deg",
    )
)
register_metric(
    Metric(
        "max_angle",
        lambda g: g.angles.max(axis=1),
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
