"""GeoJSON geometries of mesh control (refinements, constraints) into the meshing plane.

The region's rings are projected by :func:`service.geo.project_rings`; the geometries that
control the mesh go through the same :class:`~service.geo.Projection`, so they land where the
rings do. Lines and polygon rings are straight in lon/lat (RFC 7946): with ``densify`` they are
split so their pieces follow the lon/lat line in the plane, as the rings are.

>>> from service.geo import project_rings
>>> p = project_rings([([[14, 60], [16, 60], [16, 61], [14, 61]], [])], "EPSG:4326")
>>> line = project_geometry({"type": "LineString", "coordinates": [[14.5, 60.5], [15, 60.5]]}, p)
>>> line["type"], len(line["coordinates"]), round(line["coordinates"][0][1] / 1000)
('LineString', 2, 6707)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from .crs import Projection

__all__ = ["project_geometry", "snap_vertices"]


def _ring(coords: Any, projection: Projection, densify: float | None) -> list[list[float]]:
    xy = np.asarray(coords, dtype=np.float64)[:, :2]
    closed = len(xy) > 1 and np.array_equal(xy[0], xy[-1])
    out = projection.forward_path(xy[:-1] if closed else xy, closed=True, densify=densify)
    return np.vstack([out, out[:1]]).tolist()


def _line(coords: Any, projection: Projection, densify: float | None) -> list[list[float]]:
    return projection.forward_path(coords, densify=densify).tolist()


def _points(coords: Any, projection: Projection) -> list[list[float]]:
    return projection.forward(coords).tolist()


def project_geometry(
    geometry: Mapping[str, Any], projection: Projection | None, densify: float | None = None
) -> dict[str, Any]:
    """``geometry`` (a GeoJSON geometry in the input CRS) in the meshing plane of
    ``projection`` (``None``: planar, returned as it is). ``ValueError`` (or ``TypeError``,
    ``KeyError``) when it is not a geometry of a known type: the caller lets the engine name it.
    """
    if projection is None or projection.to_mesh is None:
        return dict(geometry)
    kind = geometry["type"]
    if kind == "GeometryCollection":
        parts = [project_geometry(g, projection, densify) for g in geometry["geometries"]]
        return {"type": kind, "geometries": parts}
    coords = geometry["coordinates"]
    if kind == "Point":
        return {"type": kind, "coordinates": _points([coords], projection)[0]}
    if kind == "MultiPoint":
        return {"type": kind, "coordinates": _points(coords, projection) if coords else []}
    if kind == "LineString":
        return {"type": kind, "coordinates": _line(coords, projection, densify)}
    if kind == "MultiLineString":
        return {"type": kind, "coordinates": [_line(c, projection, densify) for c in coords]}
    if kind == "Polygon":
        return {"type": kind, "coordinates": [_ring(r, projection, densify) for r in coords]}
    if kind == "MultiPolygon":
        polygons = [[_ring(r, projection, densify) for r in p] for p in coords]
        return {"type": kind, "coordinates": polygons}
    raise ValueError(f"not a GeoJSON geometry type: {kind!r}")


def snap_vertices(
    geometry: shapely.Geometry, lines: shapely.Geometry, tolerance: float
) -> shapely.Geometry:
    """``geometry`` with each vertex closer than ``tolerance`` to ``lines`` (but not on them)
    moved onto them. For projected lon/lat input, where a position on a ring's lon/lat edge
    lands a little off that edge's chord in the plane.

    >>> ring = shapely.LineString([[0, 0], [10, 0]])
    >>> shapely.get_coordinates(snap_vertices(shapely.Point(5, 1e-4), ring, 1e-3)).tolist()
    [[5.0, 0.0]]
    """

    def snap(xy: NDArray[np.float64]) -> NDArray[np.float64]:
        pts = shapely.points(xy)
        d = shapely.distance(lines, pts)
        near = (d > 0) & (d < tolerance)
        if not near.any():
            return xy
        out = xy.copy()
        on = shapely.line_interpolate_point(lines, shapely.line_locate_point(lines, pts[near]))
        out[near] = shapely.get_coordinates(on)
        return out

    return shapely.transform(geometry, snap)
