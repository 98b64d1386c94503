"""Sizes are metres on the ellipsoid across large lon/lat regions (measured with pyproj.Geod).

The hand-written equirectangular projection this replaces gave 19.06 km edges in the south and
17.42 km in the north of a 10 x 10 degree box at 55-65 N; here the plane's length error is
bounded by the stated tolerance and the mesh's edge lengths do not drift with latitude.
"""

from __future__ import annotations

import numpy as np
import pytest

from .helpers import box, edges, geodesic_lengths, mesh_lonlat


@pytest.mark.parametrize(
    ("corners", "size"),
    [
        (box(10, 55, 20, 65), 20_000.0),  # high latitude, larger than a UTM zone
        (box(-5, -5, 5, 5), 20_000.0),  # the equator
        (box(-75, -48, -65, -38), 20_000.0),  # southern mid latitudes
        (box(14, 60, 16, 61), 2_000.0),  # one UTM zone
    ],
    ids=["55-65N", "equator", "38-48S", "utm"],
)
def test_edge_lengths_on_the_ellipsoid(corners: list[list[float]], size: float) -> None:
    proj, mesh = mesh_lonlat(corners, size)
    assert proj.tolerance < 0.003  # a 10 x 10 degree box: at most 0.3 % anywhere
    e = edges(mesh)
    true = geodesic_lengths(proj.inverse(mesh.points), e)
    planar = np.hypot(*(mesh.points[e[:, 0]] - mesh.points[e[:, 1]]).T)
    # Every edge: the plane is within the stated tolerance of the ellipsoid.
    ratio = true / planar
    assert np.all(np.abs(ratio - 1.0) <= proj.tolerance + 1e-6)
    # The mean edge length is the same in the southern and northern tenth of the region.
    lat = proj.inverse(mesh.points)[e, 1].mean(axis=1)
    south, north = np.percentile(lat, [10, 90])
    lo, hi = true[lat <= south].mean(), true[lat >= north].mean()
    assert abs(lo / hi - 1.0) < 0.03
    assert 0.85 < true.mean() / size < 1.1
