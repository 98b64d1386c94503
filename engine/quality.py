"""Per-triangle quality metrics and stage summaries.

Every metric is vectorised over all triangles and registered by name in :data:`METRICS`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from .mesh import Mesh

__all__ = ["METRICS", "TriangleQuality", "shape_quality_xy", "summarize", "triangle_quality"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
Metric = Callable[[FloatArray, IntArray], FloatArray]

_SQRT3 = float(np.sqrt(3.0))


@numba.njit(cache=True, inline="always")
def shape_quality_xy(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    """:func:`shape_quality` of one triangle given by its corners, for compiled kernels."""
    area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    s = (bx - ax) ** 2 + (by - ay) ** 2 + (cx - bx) ** 2 + (cy - by) ** 2
    s += (ax - cx) ** 2 + (ay - cy) ** 2
    return 2.0 * _SQRT3 * area2 / s if s > 0.0 else 0.0


def _sides(points: FloatArray, triangles: IntArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Squared lengths of the sides opposite corners 0, 1, 2."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return (
        ((c - b) ** 2).sum(axis=1),
        ((a - c) ** 2).sum(axis=1),
        ((b - a) ** 2).sum(axis=1),
    )


def _area(points: FloatArray, triangles: IntArray) -> FloatArray:
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return 0.5 * (
        (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    )


def shape_quality(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Normalised shape measure ``4*sqrt(3)*A / (l1^2 + l2^2 + l3^2)``: 1 equilateral, 0 flat.

    Negative for inverted triangles.

    >>> eq = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    >>> round(float(shape_quality(eq, np.array([[0, 1, 2]]))[0]), 12)
    1.0
    """
    s0, s1, s2 = _sides(points, triangles)
    return 4.0 * _SQRT3 * _area(points, triangles) / np.maximum(s0 + s1 + s2, 1e-300)


def radius_ratio(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Gmsh's gamma, ``2r/R`` (inradius over circumradius): 1 equilateral, 0 flat.

    Uses ``2r/R = 16 A^2 / (l1 l2 l3 (l1 + l2 + l3))``; negative for inverted triangles.

    >>> right = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> round(float(radius_ratio(right, np.array([[0, 1, 2]]))[0]), 6)
    0.828427
    """
    s0, s1, s2 = _sides(points, triangles)
    l0, l1, l2 = np.sqrt(s0), np.sqrt(s1), np.sqrt(s2)
    area = _area(points, triangles)
    denom = np.maximum(l0 * l1 * l2 * (l0 + l1 + l2), 1e-300)
    return np.sign(area) * 16.0 * area * area / denom


def corner_angles(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Interior angles (m, 3) in degrees at corners 0, 1, 2."""
    out = np.empty((len(triangles), 3))
    for k in range(3):
        a = points[triangles[:, k]]
        u = points[triangles[:, (k + 1) % 3]] - a
        v = points[triangles[:, (k + 2) % 3]] - a
        cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
        out[:, k] = np.degrees(np.arctan2(np.abs(cross), (u * v).sum(axis=1)))
    return out


def min_angle(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Smallest interior angle of each triangle, in degrees."""
    return corner_angles(points, triangles).min(axis=1)


def max_angle(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Largest interior angle of each triangle, in degrees."""
    return corner_angles(points, triangles).max(axis=1)


#: Per-triangle metrics by name; every one takes ``(points, triangles)`` and returns ``(m,)``.
METRICS: dict[str, Metric] = {
    "quality": shape_quality,
    "radius_ratio": radius_ratio,
    "min_angle": min_angle,
    "max_angle": max_angle,
    "area": _area,
}


@dataclass(frozen=True)
class TriangleQuality:
    """Per-triangle figures of one mesh."""

    quality: FloatArray  #: 4*sqrt(3)*A / sum of squared sides
    radius_ratio: FloatArray  #: 2r/R
    min_angle: FloatArray  #: degrees
    max_angle: FloatArray  #: degrees
    area: FloatArray  #: signed area


def triangle_quality(mesh: Mesh) -> TriangleQuality:
    """Every metric of every triangle of ``mesh``."""
    p, t = mesh.points, mesh.triangles
    angles = corner_angles(p, t)
    return TriangleQuality(
        quality=shape_quality(p, t),
        radius_ratio=radius_ratio(p, t),
        min_angle=angles.min(axis=1),
        max_angle=angles.max(axis=1),
        area=_area(p, t),
    )


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
    """Summary of one stage: count; min, p5, mean, max of each metric; shares of poor triangles.

    >>> eq = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    >>> s = summarize(triangle_quality(Mesh(eq, np.array([[0, 1, 2]]))))
    >>> s["count"], round(s["quality"]["min"], 6), s["share_below_30deg"]
    (1, 1.0, 0.0)
    """
    n = int(q.quality.size)
    return {
        "count": n,
        "quality": _stats(q.quality),
        "radius_ratio": _stats(q.radius_ratio),
        "min_angle": _stats(q.min_angle),
        "max_angle": _stats(q.max_angle),
        "share_below_30deg": float(np.mean(q.min_angle < 30.0)) if n else 0.0,
        "share_quality_ge_0.91": float(np.mean(q.quality >= 0.91)) if n else 0.0,
        "inverted": int(np.count_nonzero(q.area <= 0.0)),
    }
