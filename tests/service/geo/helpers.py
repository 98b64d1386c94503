"""Shared helpers of the geodata tests: boxes and edge lengths measured on the ellipsoid."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pyproj import Geod

import engine
from service.geo import Projection, project_rings

GEOD = Geod(ellps="WGS84")


def box(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    """Counter-clockwise corners of a lon/lat box (x1 may be < x0 across the antimeridian)."""
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def mesh_lonlat(
    outer: list[list[float]], size: float, crs: str = "EPSG:4326"
) -> tuple[Projection, engine.Mesh]:
    """Project a lon/lat ring, mesh it at ``size`` metres; the projection and the planar mesh."""
    proj = project_rings([(outer, [])], crs, densify=size)
    mesh, _ = engine.mesh_region(engine.make_region(list(proj.parts)), engine.SizingParams(size))
    return proj, mesh


def edges(mesh: engine.Mesh) -> NDArray[np.int64]:
    t = mesh.triangles
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0)


def geodesic_lengths(lonlat: NDArray[np.float64], e: NDArray[np.int64]) -> NDArray[np.float64]:
    """Lengths on the WGS 84 ellipsoid of the edges ``e`` between lon/lat points."""
    a, b = lonlat[e[:, 0]], lonlat[e[:, 1]]
    _, _, d = GEOD.inv(a[:, 0], a[:, 1], b[:, 0], b[:, 1])
    return np.asarray(d, dtype=np.float64)
