"""Lon/lat rings across the 180th meridian are the small regions they are."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine
from engine.boundary import signed_area
from service.geo import crosses_antimeridian, normalize_longitudes, project_rings, unwrap_parts
from service.geo.antimeridian import split_at_antimeridian

from .helpers import box, edges, geodesic_lengths, mesh_lonlat


def test_a_box_across_the_antimeridian_is_two_degrees_wide() -> None:
    ((outer, holes),) = unwrap_parts([(box(179, -1, -179, 1), [])])
    assert holes == []
    assert np.ptp(outer[:, 0]) == pytest.approx(2.0)
    assert crosses_antimeridian([(box(179, -1, -179, 1), [])])


def test_meshing_a_box_across_the_antimeridian() -> None:
    proj, mesh = mesh_lonlat(box(179, -1, -179, 1), 20_000.0)
    lonlat = proj.inverse(mesh.points)
    assert np.all(np.abs(lonlat[:, 0]) <= 180.0)
    assert lonlat[:, 0].min() < -179.0 + 1e-6
    assert lonlat[:, 0].max() > 179.0 - 1e-6
    # No point in the 358 degrees the literal reading would cover.
    assert not np.any(np.abs(lonlat[:, 0]) < 179.0 - 1e-6)
    # About 222 x 221 km of area at the size of 20 km: a few hundred triangles, not the globe.
    area = mesh.areas.sum()
    assert area == pytest.approx(222_390.0 * 221_140.0, rel=0.01)
    d = geodesic_lengths(lonlat, edges(mesh))
    assert 0.8 < d.mean() / 20_000.0 < 1.1


def test_a_hole_across_the_antimeridian() -> None:
    outer = box(178, -2, -178, 2)
    hole = box(179.5, -0.5, -179.5, 0.5)[::-1]
    proj = project_rings([(outer, [hole])], "EPSG:4326")
    region = engine.make_region(list(proj.parts))
    degree = 111_320.0  # metres per degree at the equator
    assert region.area == pytest.approx((4 * 4 - 1) * degree**2, rel=0.01)


def test_polygons_split_at_the_antimeridian_come_back_side_by_side() -> None:
    """RFC 7946 asks writers to cut such polygons at 180 into a MultiPolygon."""
    east, west = box(178, -2, 180, 2), box(-180, -2, -178, 2)
    rings = unwrap_parts([(east, []), (west, [])])
    lon = np.concatenate([rings[0][0][:, 0], rings[1][0][:, 0]])
    assert lon.min() == pytest.approx(178.0)
    assert lon.max() == pytest.approx(182.0)
    proj = project_rings([(east, []), (west, [])], "EPSG:4326")
    (e_xy, _), (w_xy, _) = proj.parts
    # The cut is one line in the plane: the halves share it.
    assert e_xy[:, 0].max() == pytest.approx(w_xy[:, 0].min(), abs=1e-6)


def test_a_region_given_past_180_is_brought_back() -> None:
    ((outer, _),) = unwrap_parts([(box(185, 0, 187, 1), [])])
    assert outer[:, 0].min() == pytest.approx(-175.0)


@settings(max_examples=80, deadline=None)
@given(
    west=st.floats(-179.9, 179.9),
    width=st.floats(0.1, 60.0),
    lat=st.floats(-60.0, 60.0),
)
def test_unwrap_gives_the_true_width(west: float, width: float, lat: float) -> None:
    east = float(normalize_longitudes([[west + width, 0.0]])[0, 0])
    ((outer, _),) = unwrap_parts([(box(west, lat, east, lat + 1.0), [])])
    assert np.ptp(outer[:, 0]) == pytest.approx(width, abs=1e-9)
    centre = 0.5 * (outer[:, 0].min() + outer[:, 0].max())
    assert -180.0 <= centre <= 180.0


@given(st.lists(st.floats(-1000.0, 1000.0), min_size=1, max_size=20))
def test_normalized_longitudes_are_in_range_and_the_same_meridian(lons: list[float]) -> None:
    xy = np.column_stack([lons, np.zeros(len(lons))])
    out = normalize_longitudes(xy)
    assert np.all(np.abs(out[:, 0]) <= 180.0)
    turns = (xy[:, 0] - out[:, 0]) / 360.0
    np.testing.assert_allclose(turns, np.round(turns), atol=1e-9)


@settings(max_examples=80, deadline=None)
@given(
    lons=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3),
    lats=st.lists(st.floats(-60.0, 60.0), min_size=3, max_size=3),
    centre=st.sampled_from([180.0, -180.0, 179.0, 0.0]),
)
def test_split_pieces_are_in_range_and_keep_the_area(
    lons: list[float], lats: list[float], centre: float
) -> None:
    tri = np.column_stack([np.array(lons) + centre, lats])
    area = abs(signed_area(tri))
    if area < 1e-6:
        return
    pieces = split_at_antimeridian(normalize_longitudes(tri))
    assert pieces
    for outer, holes in pieces:
        assert holes == []
        assert np.all(np.abs(outer[:, 0]) <= 180.0 + 1e-9)
        assert signed_area(outer) > 0  # counter-clockwise, RFC 7946's right-hand rule
    assert sum(signed_area(o) for o, _ in pieces) == pytest.approx(area, rel=1e-9, abs=1e-9)


def test_a_mesh_across_180_written_as_rfc7946_triangles() -> None:
    proj, mesh = mesh_lonlat(box(179, -1, -179, 1), 20_000.0)
    lonlat = proj.inverse(mesh.points)
    pieces = [p for t in mesh.triangles for p in split_at_antimeridian(lonlat[t])]
    assert len(pieces) > mesh.n_triangles  # the triangles over 180 come in two pieces
    assert all(np.all(np.abs(o[:, 0]) <= 180.0) for o, _ in pieces)
    assert sum(signed_area(o) for o, _ in pieces) == pytest.approx(4.0, rel=1e-3)  # 2 x 2 deg
