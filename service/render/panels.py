"""The meshes a picture draws, read from a mesh document, and figures computed from them."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .options import METRICS, Metric, PictureError, PictureOptions

__all__ = [
    "HISTOGRAM_BINS",
    "Panel",
    "aspect_of",
    "edge_sets",
    "extent_of",
    "histogram",
    "mean_area",
    "panels_of",
    "stats_lines",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Panel:
    """One mesh to draw: coordinates, triangles, the colouring values and the quality."""

    title: str
    points: FloatArray
    triangles: NDArray[np.int64]
    values: FloatArray  #: per triangle or per node, as the metric says
    quality: FloatArray  #: per triangle (the worst are outlined, the histogram counts it)
    min_angle: FloatArray | None


def panel_of(
    title: str,
    part: Mapping[str, Any],
    point_data: Mapping[str, Any],
    fitness_key: str,
    metric: Metric,
) -> Panel:
    cells = part.get("cell_data", {})
    points = np.asarray(part["points"], dtype=np.float64).reshape(-1, 2)
    triangles = np.asarray(part["triangles"], dtype=np.int64).reshape(-1, 3)
    if not len(triangles):
        raise PictureError("f", "the result has no triangles to draw")
    if "quality" not in cells:
        raise PictureError("f", "the result has no triangle quality to draw")
    if metric.on == "point":
        if fitness_key not in point_data:
            raise PictureError("color", f"the result has no node {metric.name}")
        values = np.asarray(point_data[fitness_key], dtype=np.float64)
    else:
        if metric.name not in cells:
            raise PictureError("color", f"the result has no {metric.name}")
        values = np.asarray(cells[metric.name], dtype=np.float64)
    angles = cells.get("min_angle")
    return Panel(
        title,
        points,
        triangles,
        values,
        np.asarray(cells["quality"], dtype=np.float64),
        None if angles is None else np.asarray(angles, dtype=np.float64),
    )


def panels_of(doc: Mapping[str, Any], options: PictureOptions) -> list[Panel]:
    metric = METRICS[options.color]
    point_data = doc.get("point_data", {})
    after = panel_of("after", doc, point_data, "fitness", metric)
    if not options.compare:
        return [after]
    initial = doc.get("initial")
    if not isinstance(initial, Mapping):
        raise PictureError("compare", "the result has no initial mesh to compare with")
    params = doc.get("summary", {}).get("parameters", {})
    method = params.get("smoothing", {}).get("method")
    steps = [
        *(["swapped"] if params.get("swap", True) else []),
        *([f"smoothed ({method})"] if method not in (None, "none") else []),
    ]
    before = panel_of("before: as meshed", initial, point_data, "fitness_initial", metric)
    return [before, replace(after, title=f"after: {' and '.join(steps) or 'unchanged'}")]


def stats_lines(panel: Panel) -> list[str]:
    """The figures under a mesh's title: its size, then its quality."""
    q = panel.quality
    quality = [f"quality min {q.min():.3f}, mean {q.mean():.3f}"]
    if panel.min_angle is not None and panel.min_angle.size:
        quality.append(f"smallest angle {panel.min_angle.min():.1f}°")
        quality.append(f"{100 * np.mean(panel.min_angle < 30.0):.1f}% under 30°")
    return [f"{q.size:,} triangles  ·  {len(panel.points):,} points", "  ·  ".join(quality)]


def aspect_of(doc: Mapping[str, Any], points: FloatArray) -> float:
    """Data units of y per unit of x that make the picture true to shape: lon/lat points (a
    document whose ``crs`` is geographic, or "wgs84" before version 1.1) are stretched by
    1 / cos(latitude).

    >>> aspect_of({"crs": {"geographic": True}}, np.array([[0.0, 60.0]]))
    1.9999999999999996
    """
    crs = doc.get("crs")
    geographic = crs == "wgs84" or (isinstance(crs, Mapping) and crs.get("geographic") is True)
    if geographic and points.size:
        lat = float(np.mean(points[:, 1]))
        return 1.0 / max(math.cos(math.radians(lat)), 1e-3)
    return 1.0


def extent_of(panels: list[Panel], aspect: float) -> float:
    """Height over width of the meshes' common bounding box, on paper."""
    pts = np.concatenate([p.points for p in panels])
    span = np.ptp(pts, axis=0) if pts.size else np.ones(2)
    return float(span[1] * aspect / span[0]) if span[0] > 0 else 1.0


def edge_sets(triangles: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Every edge once, and the edges of one triangle only (the outline and the holes)."""
    pairs = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    n = int(triangles.max()) + 1 if triangles.size else 1
    # One integer per edge: sorting those is several times faster than unique rows.
    keys, counts = np.unique(pairs[:, 0] * n + pairs[:, 1], return_counts=True)
    edges = np.column_stack([keys // n, keys % n])
    return edges, edges[counts == 1]


def mean_area(pts: FloatArray, tris: NDArray[np.int64]) -> float:
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    return float(np.mean(np.abs(cross))) / 2 if len(tris) else 0.0


HISTOGRAM_BINS = 30


def histogram(quality: FloatArray, lo: float) -> tuple[FloatArray, FloatArray]:
    """Triangle counts in equal quality bins over [lo, 1], and the bin edges."""
    edges = np.linspace(lo, 1.0, HISTOGRAM_BINS + 1)
    counts = np.histogram(np.clip(quality, lo, 1.0), edges)[0].astype(np.float64)
    return counts, edges
