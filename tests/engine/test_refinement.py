"""Refinements (engine.refinement): size s on a geometry, growing away at the job's rate or
its own, combined with the region's own sizing by the minimum; meshes stay valid and conforming."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import LimitExceeded, Region, SizingParams, make_region, mesh_region
from engine.refinement import InvalidRefinement, Refinement
from engine.sizing import build_size_field

from .control_strategies import valid_regions
from .regions import assert_conforming

SQUARE = make_region([([[0, 0], [2, 0], [2, 2], [0, 2]], [])])
POINT = {"type": "Point", "coordinates": [1.0, 1.0]}
LINE = {"type": "LineString", "coordinates": [[0.5, 0.5], [1.5, 1.2]]}
BOX = {"type": "Polygon", "coordinates": [[[0.2, 0.2], [0.8, 0.2], [0.8, 0.6], [0.2, 0.6]]]}


def _field(*refinements: Refinement, growth: float = 1.2):  # type: ignore[no-untyped-def]
    return build_size_field(SQUARE, SizingParams(0.2, growth, refinements=refinements))


@pytest.mark.parametrize("geometry", [POINT, LINE, BOX])
def test_the_size_on_the_geometry_is_s_and_grows_at_the_job_rate(geometry: dict) -> None:
    s, growth = 0.02, 1.3
    field = _field(Refinement(geometry, s), growth=growth)
    geom = shapely.geometry.shape(geometry)
    on = shapely.get_coordinates(shapely.segmentize(geom, 0.003))
    # Within a quarter step of the samples, and the 5% the field's thinning allows.
    assert np.all(field(on) <= 1.05 * s * (1 + (growth - 1) / 4))
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 2, (2000, 2))
    d = shapely.distance(geom, shapely.points(xy))
    h = field(xy)
    assert np.all(h <= 1.05 * (s + (growth - 1) * (d + s / 4)))  # grows no faster
    assert np.all(h >= np.minimum(0.2, s + (growth - 1) * (d - 0.01 * s)) - 1e-12)
    assert np.all(h <= 0.2)


def test_inside_a_polygon_refinement_the_size_is_s() -> None:
    field = _field(Refinement(BOX, 0.05))
    gx, gy = np.meshgrid(np.linspace(0.21, 0.79, 30), np.linspace(0.21, 0.59, 20))
    # Samples every s/2: within s/3 of one, plus the 5% the thinning allows.
    assert field(np.c_[gx.ravel(), gy.ravel()]).max() <= 0.05 * 1.05 * (1 + 0.2 / 3)


def test_a_coarser_refinement_changes_nothing() -> None:
    xy = np.random.default_rng(1).uniform(0, 2, (500, 2))
    assert np.array_equal(_field(Refinement(BOX, 0.5))(xy), _field()(xy))


def test_a_point_refinement_makes_small_triangles_near_it_only() -> None:
    params = SizingParams(0.2, refinements=(Refinement(POINT, 0.02),))
    mesh, _ = mesh_region(SQUARE, params)
    plain, _ = mesh_region(SQUARE, SizingParams(0.2))
    assert_conforming(mesh, SQUARE)
    edges = mesh.points[mesh.triangles] - np.roll(mesh.points[mesh.triangles], 1, axis=1)
    length = np.linalg.norm(edges, axis=2).mean(axis=1)
    dist = np.hypot(*(mesh.points[mesh.triangles].mean(axis=1) - 1.0).T)
    assert length[dist < 0.04].mean() < 0.035
    assert length[dist > 0.9].mean() > 0.15
    assert mesh.n_triangles > plain.n_triangles + 100


@pytest.mark.parametrize("own", [1.05, 1.6])
def test_a_refinement_grows_at_its_own_rate(own: float) -> None:
    s, job = 0.02, 1.2
    field = _field(Refinement(POINT, s, growth=own), growth=job)
    xy = np.random.default_rng(3).uniform(0, 2, (2000, 2))
    d = np.hypot(*(xy - 1.0).T)
    h = field(xy)
    assert np.all(h <= np.minimum(0.2, 1.05 * (s + (own - 1) * (d + s / 4))) + 1e-12)
    assert np.all(h >= np.minimum(0.2, s + (own - 1) * (d - 0.01 * s)) - 1e-12)
    # At the job's rate the field differs wherever it is below the region's size.
    ring = np.c_[1 + 0.3 * np.cos(np.arange(8)), 1 + 0.3 * np.sin(np.arange(8))]
    assert not np.allclose(field(ring), _field(Refinement(POINT, s), growth=job)(ring))


def test_refinements_growing_at_different_rates_combine_by_the_minimum() -> None:
    slow = Refinement(POINT, 0.02, growth=1.05)
    fast = Refinement(LINE, 0.01, growth=1.8)
    xy = np.random.default_rng(4).uniform(0, 2, (1500, 2))
    both = _field(slow, fast)(xy)
    assert np.allclose(both, np.minimum(_field(slow)(xy), _field(fast)(xy)), rtol=0.011)


@pytest.mark.parametrize(
    ("geometry", "size", "growth"),
    [
        ({"type": "Point"}, 0.1, None),
        ({"type": "Spiral", "coordinates": []}, 0.1, None),
        (POINT, 0.0, None),
        (POINT, 0.1, 1.0),
        (POINT, 0.1, float("nan")),
    ],
)
def test_bad_refinements_are_typed_errors(geometry: dict, size: float, growth: float) -> None:
    with pytest.raises(InvalidRefinement, match="a refinement's"):
        Refinement(geometry, size, growth)


@st.composite
def refinements(draw: st.DrawFn, bounds: tuple[float, float, float, float]) -> Refinement:
    x0, y0, x1, y1 = bounds
    span = max(x1 - x0, y1 - y0)
    coord = st.tuples(st.floats(x0, x1), st.floats(y0, y1)).map(list)
    kind = draw(st.sampled_from(["Point", "LineString", "Polygon"]))
    if kind == "Point":
        geometry = {"type": kind, "coordinates": draw(coord)}
    elif kind == "LineString":
        geometry = {"type": kind, "coordinates": draw(st.lists(coord, min_size=2, max_size=4))}
    else:
        c, r = draw(coord), draw(st.floats(0.02, 0.2)) * span
        geometry = shapely.geometry.mapping(shapely.Point(c).buffer(r, 4))
    growth = draw(st.none() | st.floats(1.05, 2.0))
    return Refinement(geometry, draw(st.floats(0.02, 0.2)) * span, growth)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=valid_regions(), data=st.data())
def test_random_regions_with_random_refinements_mesh_valid_and_conforming(
    case: tuple[Region, float], data: st.DataObject
) -> None:
    region, size = case
    refs = tuple(data.draw(st.lists(refinements(region.bounds), min_size=1, max_size=3)))
    mesh, _ = mesh_region(region, SizingParams(size, refinements=refs))
    assert_conforming(mesh, region)


def test_a_zero_length_line_refines_like_its_point() -> None:
    dot = {"type": "LineString", "coordinates": [[1.0, 1.0], [1.0, 1.0]]}
    xy = np.random.default_rng(2).uniform(0, 2, (300, 2))
    assert np.array_equal(_field(Refinement(dot, 0.02))(xy), _field(Refinement(POINT, 0.02))(xy))


def test_a_line_is_a_feature_per_segment_and_exactly_s_along_it() -> None:
    # Sampled every s / 2 a line at s = 1e-7 made 22 million features (a minute and gigabytes
    # before the estimate refused it); as its segments it makes one per segment, at any size.
    zigzag = {"type": "LineString", "coordinates": [[0.1, 0.1], [1.9, 0.4], [0.2, 1.8]]}
    field = _field(Refinement(zigzag, 1e-7))
    assert field.feature_h.size < 20
    on = shapely.get_coordinates(shapely.segmentize(shapely.geometry.shape(zigzag), 0.01))
    np.testing.assert_allclose(field(on), 1e-7, rtol=1e-9)
    with pytest.raises(LimitExceeded, match="triangles, over the limit"):
        mesh_region(SQUARE, SizingParams(0.2, refinements=(Refinement(zigzag, 1e-7),)))


def test_a_polygon_is_its_edges_and_chords_s_over_two_apart() -> None:
    # As a grid of points every s / 2 this box at 1e-4 was 96 million samples (refused); as
    # chords it is one feature per s / 2 of its height, and the size inside stays within the
    # quarter step of s (and the 5% the field's thinning allows).
    s, growth = 1e-4, 1.2
    field = _field(Refinement(BOX, s), growth=growth)
    assert field.feature_h.size <= 0.4 / (s / 2) + 10
    inside = np.random.default_rng(1).uniform([0.2, 0.2], [0.8, 0.6], (5000, 2))
    assert np.all(field(inside) <= 1.05 * s * (1 + (growth - 1) / 4))


def test_a_polygon_with_a_hole_refines_around_the_hole_only() -> None:
    # Chords stop at the hole: its middle, 0.3 from any edge, grows away from s.
    ring = [[0.2, 0.2], [1.8, 0.2], [1.8, 1.8], [0.2, 1.8], [0.2, 0.2]]
    hole = [[0.7, 0.7], [0.7, 1.3], [1.3, 1.3], [1.3, 0.7], [0.7, 0.7]]
    s, growth = 0.01, 1.2
    field = _field(Refinement({"type": "Polygon", "coordinates": [ring, hole]}, s), growth=growth)
    assert field(np.array([[1.0, 1.0]]))[0] > 0.99 * (s + (growth - 1) * 0.3)
    assert field(np.array([[0.45, 1.0]]))[0] <= 1.05 * s * (1 + (growth - 1) / 4)
