"""Diagonal swapping keeps the mesh valid and leaves no improving flip behind."""

from __future__ import annotations

import json

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import PipelineParams, SizingParams, SmoothingParams, mesh_then_smooth
from engine.errors import InvalidBoundary
from engine.mesh import Mesh, edge_table, validate_mesh
from engine.quality import shape_quality
from engine.swap import regularise_valence, swap_diagonals

from ..conftest import DATA
from .random_meshes import meshes, random_mesh
from .regions import Rings, region_of, regions


def _undirected(edges: np.ndarray) -> set[tuple[int, int]]:
    return {(int(min(a, b)), int(max(a, b))) for a, b in edges}


def _improving_flips(mesh: Mesh) -> list[tuple[int, int]]:
    """Interior edges whose flip would raise the worse quality of their pair (brute force)."""
    tri, pts = mesh.triangles, mesh.points
    _edges, count, edge_of = edge_table(tri)
    q = shape_quality(pts, tri)
    found = []
    for e in np.flatnonzero(count == 2):
        (t1, k1), (t2, k2) = np.argwhere(edge_of == e)
        c, a, b = tri[t1, k1], tri[t1, (k1 + 1) % 3], tri[t1, (k1 + 2) % 3]
        d = tri[t2, k2]
        new = shape_quality(pts, np.array([[c, a, d], [d, b, c]])).min()
        old = min(q[t1], q[t2])
        if new > 0 and new > old * (1 + 1e-9):
            found.append((int(a), int(b)))
    return found


@settings(max_examples=40, deadline=None)
@given(mesh=meshes())
def test_swapping_keeps_the_mesh_valid_and_is_locally_optimal(mesh: Mesh) -> None:
    out = swap_diagonals(mesh)
    validate_mesh(out.points, out.triangles)
    assert out.points is mesh.points
    assert out.n_triangles == mesh.n_triangles
    assert _undirected(out.boundary_edges) == _undirected(mesh.boundary_edges)
    assert np.isclose(out.areas.sum(), mesh.areas.sum(), rtol=1e-12)
    q_before = shape_quality(mesh.points, mesh.triangles)
    q_after = shape_quality(out.points, out.triangles)
    assert q_after.min() >= q_before.min()
    assert _improving_flips(out) == []
    np.testing.assert_array_equal(swap_diagonals(out).triangles, out.triangles)


@settings(max_examples=25, deadline=None)
@given(mesh=meshes(), pick=st.integers(0, 2**32 - 1))
def test_fixed_edges_never_flip(mesh: Mesh, pick: int) -> None:
    edges, count, _ = edge_table(mesh.triangles)
    interior = edges[count == 2]
    rng = np.random.default_rng(pick)
    fixed = interior[rng.random(len(interior)) < 0.5]
    out = swap_diagonals(mesh, fixed_edges=fixed[:, ::-1])  # either vertex order
    validate_mesh(out.points, out.triangles)
    after = _undirected(edge_table(out.triangles)[0])
    assert _undirected(fixed) <= after


@settings(max_examples=25, deadline=None)
@given(mesh=meshes())
def test_relaxing_before_swapping_moves_only_interior_nodes_and_never_worsens(mesh: Mesh) -> None:
    out = swap_diagonals(mesh, relax=True)
    validate_mesh(out.points, out.triangles)
    boundary = mesh.boundary_nodes
    np.testing.assert_array_equal(out.points[boundary], mesh.points[boundary])
    assert _undirected(out.boundary_edges) == _undirected(mesh.boundary_edges)
    assert np.isclose(out.areas.sum(), mesh.areas.sum(), rtol=1e-12)
    q_before = shape_quality(mesh.points, mesh.triangles).min()
    assert shape_quality(out.points, out.triangles).min() >= q_before - 1e-12
    assert _improving_flips(out) == []


def test_a_sliver_pair_is_flipped_and_a_dart_is_not() -> None:
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.1, 0.2], [0.0, 0.25]])
    out = swap_diagonals(Mesh(pts, np.array([[0, 1, 2], [0, 2, 3]])))
    assert _undirected(edge_table(out.triangles)[0]) >= {(1, 3)}
    # Non-convex quadrilateral (a dart): the other diagonal lies outside, never flip.
    dart = np.array([[0.0, 0.0], [2.0, 0.0], [0.5, 0.2], [0.0, 2.0]])
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    np.testing.assert_array_equal(swap_diagonals(Mesh(dart, tri)).triangles, tri)


def test_swapping_a_large_jittered_mesh_improves_its_worst_triangle() -> None:
    doc = json.loads((DATA / "poor" / "unit_square.poor.json").read_text())
    mesh = validate_mesh(doc["points"], doc["triangles"])
    out = swap_diagonals(mesh)
    validate_mesh(out.points, out.triangles)
    worst_before = shape_quality(mesh.points, mesh.triangles).min()
    assert shape_quality(out.points, out.triangles).min() > 2 * worst_before
    assert _undirected(out.boundary_edges) == _undirected(mesh.boundary_edges)


def test_swapping_does_not_modify_its_input() -> None:
    mesh = random_mesh(7)
    before = mesh.triangles.copy()
    swap_diagonals(mesh)
    np.testing.assert_array_equal(mesh.triangles, before)


def _irregularity(mesh: Mesh) -> int:
    valence = np.bincount(mesh.triangles.ravel(), minlength=len(mesh.points))
    interior = np.ones(len(mesh.points), dtype=bool)
    interior[mesh.boundary_nodes] = False
    return int(((valence[interior] - 6) ** 2).sum())


@settings(max_examples=25, deadline=None)
@given(mesh=meshes())
def test_valence_flips_lower_irregularity_and_keep_the_mesh_valid(mesh: Mesh) -> None:
    swapped = swap_diagonals(mesh, relax=True)
    out = regularise_valence(swapped)
    if out is None:
        return
    validate_mesh(out.points, out.triangles)
    assert _irregularity(out) < _irregularity(swapped)
    boundary = swapped.boundary_nodes
    np.testing.assert_array_equal(out.points[boundary], swapped.points[boundary])
    assert _undirected(out.boundary_edges) == _undirected(swapped.boundary_edges)
    assert np.isclose(out.areas.sum(), swapped.areas.sum(), rtol=1e-12)
    assert shape_quality(out.points, out.triangles).min() >= 0.5 - 1e-12 or (
        shape_quality(out.points, out.triangles).min()
        >= shape_quality(swapped.points, swapped.triangles).min() - 1e-12
    )


@settings(max_examples=15, deadline=None)
@given(regions())
def test_the_pipeline_never_ends_below_its_starting_worst(case: tuple[Rings, float]) -> None:
    rings, size = case
    try:
        region = region_of(rings)
    except InvalidBoundary:
        return
    quick = SmoothingParams(population=12, generations=6, max_sweeps=3)
    result = mesh_then_smooth(
        region,
        PipelineParams(SizingParams(size=size), smoothing=quick),
        rng=np.random.default_rng(1),
    )
    final = result.smoothed.mesh
    validate_mesh(final.points, final.triangles)
    assert result.smoothed.quality.quality.min() >= result.initial.quality.quality.min() - 1e-12
