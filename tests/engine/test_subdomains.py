"""Subdomains (engine.subdomains): polygons sharing edges mesh as one conforming mesh, each with
its own size; interfaces are meshed once, never flipped, their nodes never moved."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import PipelineParams, SizingParams, SmoothingParams, Tagging, tag_mesh
from engine.errors import InvalidBoundary
from engine.mesh import edge_table
from engine.subdomains import mesh_subdomains

LEFT = ([[0, 0], [1, 0], [1, 1], [0, 1]], [])
#: Shares part of LEFT's right edge: a T-junction at (1, 0.5) and (1, 1).
RIGHT = ([[1, 0.5], [2, 0.5], [2, 1.5], [1, 1.5]], [])


def _params(method: str = "laplacian", size: float = 0.2) -> PipelineParams:
    return PipelineParams(SizingParams(size), smoothing=SmoothingParams(method))


def _check(sub, polys) -> None:  # type: ignore[no-untyped-def]
    mesh = sub.result.smoothed.mesh
    assert sub.result.smoothed.summary["inverted"] == 0
    _, count, _ = edge_table(mesh.triangles)
    assert count.max() <= 2
    union = shapely.union_all(polys)
    assert np.isclose(np.abs(mesh.areas).sum(), union.area)
    # Every triangle lies in its own polygon, and each polygon is covered exactly.
    c = mesh.points[mesh.triangles].mean(axis=1)
    for i, poly in enumerate(polys):
        mine = sub.triangle_region == i + 1
        assert shapely.contains_xy(poly, c[mine, 0], c[mine, 1]).all()
        assert np.isclose(np.abs(mesh.areas[mine]).sum(), poly.area)


def test_two_polygons_sharing_part_of_an_edge_mesh_as_one() -> None:
    sub = mesh_subdomains([LEFT, RIGHT], _params(), sizes=[0.2, 0.07])
    polys = [shapely.Polygon(LEFT[0]), shapely.Polygon(RIGHT[0])]
    _check(sub, polys)
    mesh = sub.result.smoothed.mesh
    # Each keeps its own size: the right one (0.07) is much denser.
    density = [np.sum(sub.triangle_region == k) / polys[k - 1].area for k in (1, 2)]
    assert density[1] > 2 * density[0]  # the left one grades in from the interface
    tags = tag_mesh(mesh, sub.region)
    assert tags.regions == {"region-0": 1, "region-1": 2}
    assert "region-0|region-1" in tags.tags
    shared = tags.lines[tags.line_tag == tags.tags["region-0|region-1"]]
    mid = mesh.points[shared].mean(axis=1)
    assert np.allclose(mid[:, 0], 1.0)
    length = np.linalg.norm(np.diff(mesh.points[shared], axis=1)[:, 0], axis=1).sum()
    assert np.isclose(length, 0.5)  # the common part, meshed once


def test_interface_nodes_stay_put_through_swapping_and_smoothing() -> None:
    sub = mesh_subdomains([LEFT, RIGHT], _params("ga"), sizes=[0.25, 0.1])
    first, final = sub.result.initial.mesh, sub.result.smoothed.mesh
    on = np.isclose(first.points[:, 0], 1.0) & (first.points[:, 1] > 0.5 - 1e-12)
    on &= first.points[:, 1] < 1 + 1e-12
    assert on.sum() > 4
    assert np.array_equal(final.points[on], first.points[on])
    _check(sub, [shapely.Polygon(LEFT[0]), shapely.Polygon(RIGHT[0])])


def test_an_island_filling_a_hole_is_a_subdomain() -> None:
    hole = [[0.3, 0.3], [0.7, 0.3], [0.7, 0.7], [0.3, 0.7]]
    lake = ([[0, 0], [1, 0], [1, 1], [0, 1]], [hole])
    island = (hole, [])
    sub = mesh_subdomains([lake, island], _params(), sizes=[0.15, 0.05])
    _check(sub, [shapely.Polygon(lake[0], [hole]), shapely.Polygon(hole)])
    tags = tag_mesh(sub.result.smoothed.mesh, sub.region, Tagging(names=["lake", "island"]))
    assert set(tags.tags) == {"lake/outer", "lake|island"}


def test_overlapping_polygons_are_a_located_error() -> None:
    other = ([[0.5, 0.5], [1.5, 0.5], [1.5, 1.5], [0.5, 1.5]], [])
    with pytest.raises(InvalidBoundary, match="polygons 0 and 1 overlap near") as err:
        mesh_subdomains([LEFT, other], _params())
    assert err.value.part == 1
    x, y = err.value.location  # type: ignore[misc]
    assert 0.5 <= x <= 1
    assert 0.5 <= y <= 1


def test_a_bad_polygon_is_named() -> None:
    bow = ([[2, 0], [3, 1], [3, 0], [2, 1]], [])
    with pytest.raises(InvalidBoundary, match=r"polygon 1: .*intersects itself") as err:
        mesh_subdomains([LEFT, bow], _params())
    assert err.value.part == 1


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    cuts=st.lists(st.sampled_from([0.2, 0.4, 0.6, 0.8]), min_size=1, max_size=4, unique=True),
    kinks=st.lists(st.floats(-0.08, 0.08), min_size=4, max_size=4),
    sizes=st.lists(st.sampled_from([None, 0.05, 0.1, 0.3]), min_size=5, max_size=5),
)
def test_random_strips_with_kinked_interfaces_conform(
    cuts: list[float], kinks: list[float], sizes: list[float | None]
) -> None:
    """A square cut into strips by kinked polylines: any sizes, any number of strips."""
    lines = [[[0.0, 0.0], [0.0, 1.0]]]
    lines += [[[x, 0.0], [x + k, 0.5], [x, 1.0]] for x, k in zip(sorted(cuts), kinks, strict=False)]
    lines += [[[1.0, 0.0], [1.0, 1.0]]]
    parts = [([*a, *b[::-1]], []) for a, b in itertools.pairwise(lines)]
    sub = mesh_subdomains(parts, _params("none"), sizes=sizes[: len(parts)])
    _check(sub, [shapely.Polygon(p[0]) for p in parts])


def test_the_same_seed_gives_the_same_subdomain_mesh() -> None:
    a, b = (
        mesh_subdomains([LEFT, RIGHT], _params("ga"), [0.25, 0.1], np.random.default_rng(5))
        for _ in range(2)
    )
    assert np.array_equal(a.result.smoothed.mesh.points, b.result.smoothed.mesh.points)
    assert np.array_equal(a.triangle_region, b.triangle_region)
