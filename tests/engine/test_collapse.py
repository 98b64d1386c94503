"""Edge collapse: valid, boundary unchanged, the worst triangle never lower, defects repaired."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings

from engine.collapse import collapse_edges
from engine.discretize import discretize
from engine.errors import InvalidBoundary
from engine.front import advance_front
from engine.mesh import Mesh, validate_mesh
from engine.params import SizingParams
from engine.quality import shape_quality, triangle_quality
from engine.relax import relax
from engine.sizing import build_size_field

from .random_meshes import meshes
from .regions import Rings, assert_conforming, region_of, regions


def _boundary(mesh: Mesh) -> set[tuple[tuple[float, float], tuple[float, float]]]:
    """Boundary edges by coordinates (node numbers change when nodes merge)."""
    p = mesh.points
    return {(tuple(p[a]), tuple(p[b])) for a, b in mesh.boundary_edges.tolist()}


def _check(before: Mesh, after: Mesh) -> None:
    validate_mesh(after.points, after.triangles)
    assert np.all(after.areas > 0)
    np.testing.assert_allclose(after.areas.sum(), before.areas.sum(), rtol=1e-9)
    assert _boundary(after) == _boundary(before)
    # Each collapse removes one node and two triangles.
    gone = before.n_points - after.n_points
    assert before.n_triangles - after.n_triangles == 2 * gone
    worst_before = shape_quality(before.points, before.triangles).min()
    assert shape_quality(after.points, after.triangles).min() >= worst_before


@settings(max_examples=40, deadline=None)
@given(mesh=meshes())
def test_collapsing_random_meshes_keeps_them_valid_and_never_lowers_the_worst(mesh: Mesh) -> None:
    _check(mesh, collapse_edges(mesh))


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(regions())
def test_collapsing_the_front_keeps_random_regions_conforming(case: tuple[Rings, float]) -> None:
    rings, size = case
    try:
        region = region_of(rings)
    except InvalidBoundary:
        return
    field = build_size_field(region, SizingParams(size=size))
    front = relax(advance_front(discretize(region, field), field), 3)
    out = collapse_edges(front)
    _check(front, out)
    assert_conforming(out, region)


def test_two_nodes_where_one_belongs_become_one() -> None:
    ring = [[np.cos(a), np.sin(a)] for a in np.linspace(0, 2 * np.pi, 7)[:-1]]
    pts = np.array([*ring, [-0.05, 0.0], [0.05, 0.0]])
    tris = [[6, 1, 2], [6, 2, 3], [6, 3, 4], [6, 4, 7], [7, 4, 5], [7, 5, 0], [7, 0, 1], [7, 1, 6]]
    out = collapse_edges(Mesh(pts, np.array(tris)))
    assert (out.n_points, out.n_triangles) == (7, 6)
    np.testing.assert_allclose(out.points[6], [0.0, 0.0], atol=1e-6)
    assert triangle_quality(out).min_angle.min() > 59.9


def test_an_interior_node_merges_into_a_boundary_node_that_stays_put() -> None:
    # A square fan whose centre node sits almost on a boundary node's position.
    pts = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1], [0.02, 0.03]])
    tris = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    out = collapse_edges(Mesh(pts, tris))
    assert (out.n_points, out.n_triangles) == (4, 2)
    assert {tuple(p) for p in out.points.tolist()} == {(0, 0), (1, 0), (1, 1), (0, 1)}


def test_a_good_mesh_is_left_alone() -> None:
    pts = np.array([[0.0, 0], [1, 0], [0.5, np.sqrt(3) / 2], [0.5, -np.sqrt(3) / 2]])
    mesh = Mesh(pts, np.array([[0, 1, 2], [1, 0, 3]]))
    assert collapse_edges(mesh) is mesh


def test_collapse_does_not_modify_its_input() -> None:
    pts = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1], [0.02, 0.03]])
    tris = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    mesh = Mesh(pts.copy(), tris.copy())
    collapse_edges(mesh)
    np.testing.assert_array_equal(mesh.points, pts)
    np.testing.assert_array_equal(mesh.triangles, tris)
