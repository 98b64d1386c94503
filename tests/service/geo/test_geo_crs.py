"""CRS resolution, the choice of a local projection, round trips and the region limits."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import CRS

from service.geo import (
    InvalidCoordinates,
    RegionTooLarge,
    UnknownCRS,
    crs_name,
    legacy_crs,
    local_crs,
    project_rings,
    resolve_crs,
)

from .helpers import box


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("wgs84", "OGC:CRS84"),
        ("EPSG:4326", "EPSG:4326"),
        ("OGC:CRS84", "OGC:CRS84"),
        ("urn:ogc:def:crs:EPSG::32633", "EPSG:32633"),
        ("EPSG:32633", "EPSG:32633"),
    ],
)
def test_resolve_known_names(text: str, expected: str) -> None:
    assert crs_name(resolve_crs(text)) == expected


def test_resolve_proj_string() -> None:
    crs = resolve_crs("+proj=utm +zone=33 +datum=WGS84 +units=m +no_defs")
    assert crs.is_projected
    assert crs.utm_zone == "33N"


@pytest.mark.parametrize("text", ["EPSG:999999", "not a crs", "EPSG:4978"])
def test_unknown_or_unusable_crs_names_the_input(text: str) -> None:
    with pytest.raises(UnknownCRS) as info:
        resolve_crs(text)
    assert repr(text) in info.value.message
    assert info.value.crs == text


def test_legacy_crs_member() -> None:
    fc = {
        "type": "FeatureCollection",
        "features": [],
        "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
    }
    assert resolve_crs(legacy_crs(fc) or "").to_epsg() == 32633
    assert legacy_crs({"type": "FeatureCollection", "features": []}) is None
    with pytest.raises(UnknownCRS, match="linked"):
        legacy_crs({"crs": {"type": "link", "properties": {"href": "x"}}})


@pytest.mark.parametrize(
    ("corners", "epsg"),
    [
        (box(14, 60, 16, 61), 32633),  # zone 33N
        (box(-70.5, -33.5, -70.0, -33.0), 32719),  # zone 19S
        (box(0.5, -0.5, 1.5, 0.5), 32631),  # straddles the equator: the centre's hemisphere
    ],
)
def test_a_region_inside_one_zone_is_meshed_in_utm(corners: list[list[float]], epsg: int) -> None:
    assert local_crs(np.array(corners, dtype=float)).to_epsg() == epsg


@pytest.mark.parametrize(
    "corners",
    [
        box(10, 55, 20, 65),  # wider than a zone
        box(11, 50, 13, 51),  # 2 degrees wide but across the 12 E zone border
        box(0, 85, 5, 86),  # beyond UTM's latitudes
    ],
)
def test_other_regions_get_an_azimuthal_equidistant_projection(corners: list[list[float]]) -> None:
    crs = local_crs(np.array(corners, dtype=float))
    assert crs.to_epsg() is None
    assert crs.coordinate_operation is not None
    assert crs.coordinate_operation.method_name.endswith("Azimuthal Equidistant")


def test_local_projection_keeps_the_input_datum() -> None:
    crs = local_crs(np.array(box(14, 60, 16, 61), dtype=float), CRS.from_epsg(4258))
    assert crs.to_epsg() == 25833  # ETRS89 / UTM 33N, not WGS 84: no datum shift is applied


@settings(max_examples=60, deadline=None)
@given(
    lon=st.floats(12.0, 18.0),
    lat=st.floats(-79.0, 83.0),
)
def test_utm_round_trip(lon: float, lat: float) -> None:
    proj = project_rings([(box(12, -79, 18, 83), [])], "EPSG:4326")
    assert proj.mesh_crs is not None
    assert proj.mesh_crs.to_epsg() == 32633
    xy = proj.forward([[lon, lat]])
    back = proj.inverse(xy)
    np.testing.assert_allclose(back, [[lon, lat]], rtol=0, atol=1e-9)
    np.testing.assert_allclose(proj.forward(back), xy, rtol=0, atol=1e-6)


def test_projected_input_is_meshed_in_its_own_coordinates() -> None:
    ring = [[500_000.0, 6_650_000.0], [510_000.0, 6_650_000.0], [510_000.0, 6_660_000.0]]
    proj = project_rings([(ring, [])], "EPSG:32633")
    assert proj.mesh_crs == proj.source_crs
    assert not proj.geographic
    np.testing.assert_array_equal(proj.parts[0][0], ring)
    np.testing.assert_array_equal(proj.inverse(ring), ring)
    # UTM's scale is 0.9996 on the central meridian (x = 500 km): lengths are 0.04 % short there.
    assert proj.tolerance == pytest.approx(4e-4, rel=0.05)


def test_planar_input_without_crs_is_the_identity() -> None:
    proj = project_rings([([[0, 0], [1, 0], [0, 1]], [[[0.1, 0.1], [0.2, 0.1], [0.1, 0.2]]])], None)
    assert proj.source_crs is None
    assert proj.tolerance == 0.0
    np.testing.assert_array_equal(proj.parts[0][1][0], [[0.1, 0.1], [0.2, 0.1], [0.1, 0.2]])
    np.testing.assert_array_equal(proj.forward([[3.0, 4.0]]), [[3.0, 4.0]])


def test_a_region_wider_than_a_hemisphere_is_refused() -> None:
    # Vertices every 50 degrees: consecutive ones more than 180 apart would cross the antimeridian.
    south = [[lon, -10.0] for lon in range(-100, 101, 50)]
    ring = south + [[lon, 10.0] for lon, _ in reversed(south)]
    with pytest.raises(RegionTooLarge, match=r"99\.8 degrees of arc"):
        project_rings([(ring, [])], "EPSG:4326")


def test_a_ring_round_a_pole_is_refused() -> None:
    ring = [[lon, 80.0] for lon in range(-180, 180, 30)]
    with pytest.raises(RegionTooLarge, match="pole"):
        project_rings([(ring, [])], "wgs84")


def test_scale_error_limit() -> None:
    corners = box(-30, -30, 30, 30)
    proj = project_rings([(corners, [])], "EPSG:4326")
    assert 0.02 < proj.tolerance < 0.1
    with pytest.raises(RegionTooLarge, match="allowed"):
        project_rings([(corners, [])], "EPSG:4326", max_scale_error=0.01)


def test_latitudes_beyond_the_poles_point_at_the_vertex() -> None:
    with pytest.raises(InvalidCoordinates) as info:
        project_rings([(box(0, 0, 1, 1), []), (box(2, 0, 3, 95), [])], "EPSG:4326")
    assert (info.value.part, info.value.ring, info.value.vertex) == (1, 0, 2)


def test_densified_edges_stay_on_their_parallel() -> None:
    """RFC 7946 edges are straight in lon/lat: the north edge of a box is a parallel."""
    proj = project_rings([(box(10, 55, 20, 65), [])], "EPSG:4326", densify=5_000.0)
    outer = proj.parts[0][0]
    seg = np.hypot(*np.diff(np.vstack([outer, outer[:1]]), axis=0).T)
    assert seg.max() <= 5_000.0 * 1.01  # split evenly in lon/lat, so within 1 % of 5 km
    lonlat = proj.inverse(outer)
    north = lonlat[np.abs(lonlat[:, 1] - 65.0) < 1e-6]
    assert len(north) > 40  # ~470 km of parallel in pieces of at most 5 km
    assert np.ptp(north[:, 0]) == pytest.approx(10.0)


def test_projection_pickles_for_workers() -> None:
    proj = project_rings([(box(10, 55, 20, 65), [])], "EPSG:4326")
    again = pickle.loads(pickle.dumps(proj))
    np.testing.assert_allclose(again.forward([[15.0, 60.0]]), proj.forward([[15.0, 60.0]]))
    np.testing.assert_allclose(again.inverse([[1e5, 1e5]]), proj.inverse([[1e5, 1e5]]))


def test_constraint_lines_across_the_antimeridian_stay_short() -> None:
    proj = project_rings([(box(178, -2, -178, 2), [])], "EPSG:4326")
    line = proj.forward_path([[179.0, 0.0], [-179.0, 0.0]], densify=10_000.0)
    assert np.hypot(*(line[-1] - line[0])) == pytest.approx(222_639.0, rel=1e-3)  # 2 degrees
    assert len(line) == 24  # 23 pieces of at most ~10 km, and both ends kept
    np.testing.assert_allclose(
        proj.inverse(line[[0, -1]]), [[179.0, 0.0], [-179.0, 0.0]], atol=1e-9
    )
    ring = proj.forward_path(box(179, -1, -179, 1), closed=True, densify=50_000.0)
    assert len(ring) == 4 * 5  # each 2-degree side in 5 pieces; the ring stays open


def test_projected_paths_are_not_densified() -> None:
    proj = project_rings([(box(500_000, 6e6, 600_000, 6.1e6), [])], "EPSG:32633")
    line = [[500_000.0, 6e6], [600_000.0, 6e6]]
    np.testing.assert_array_equal(proj.forward_path(line, densify=1_000.0), line)


def test_describe_for_the_result_document() -> None:
    facts = project_rings([(box(10, 55, 20, 65), [])], "EPSG:4326").describe()
    assert facts["input"] == "EPSG:4326"
    assert facts["mesh"].startswith("PROJCRS[")  # a local projection has no code: its WKT
    assert facts["mesh_name"].startswith("Azimuthal equidistant")
    assert facts["geographic"] is True
    assert 0.001 < facts["length_tolerance"] < 0.002
    assert project_rings([([[0, 0], [1, 0], [0, 1]], [])], None).describe()["input"] is None


def test_public_surface() -> None:
    import service.geo

    assert set(service.geo.__all__) == {
        "ALIASES", "GeoError", "InvalidCoordinates", "MissingDependency", "Projection",
        "RegionFile", "RegionFileError", "RegionTooLarge", "UnknownCRS", "crosses_antimeridian",
        "crs_name", "legacy_crs", "local_crs", "normalize_longitudes", "project_rings",
        "read_region_file", "resolve_crs", "unwrap_parts",
    }  # fmt: skip
    assert all(hasattr(service.geo, name) for name in service.geo.__all__)


def test_a_non_finite_position_points_at_the_vertex() -> None:
    ring = [[0.0, 0.0], [1.0, 0.0], [float("nan"), 1.0]]
    with pytest.raises(InvalidCoordinates, match="finite") as info:
        project_rings([(box(5, 5, 6, 6), [ring])], "OGC:CRS84")
    assert (info.value.part, info.value.ring, info.value.vertex) == (0, 1, 2)


def test_densified_vertices_point_back_at_the_input() -> None:
    hole = box(14.5, 60.2, 15.5, 60.8)[::-1]
    proj = project_rings([(box(14, 60, 16, 61), [hole])], "EPSG:4326", densify=10_000.0)
    outer, (inner,) = proj.parts[0]
    assert len(outer) > 4
    assert len(inner) > 4
    # The third input corner (16, 61) is where the third input edge starts.
    corner = int(np.argmin(np.hypot(*(proj.inverse(outer) - [16.0, 61.0]).T)))
    assert proj.input_vertex(0, 0, corner) == 2
    assert proj.input_vertex(0, 0, corner - 1) == 1  # the last piece of the edge before it
    assert proj.input_vertex(0, 1, len(inner) - 1) == 3
    assert project_rings([(box(14, 60, 16, 61), [])], "EPSG:4326").input_vertex(0, 0, 3) == 3
