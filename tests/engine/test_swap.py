"""Diagonal swapping keeps the mesh valid and leaves no improving flip behind."""

from __future__ import annotations

import json

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from engine import PipelineParams, SizingParams, SmoothingParams, mesh_then_smooth
from engine.errors import InvalidBoundary
from engine.mesh import Mesh, corner_order, edge_table, validate_mesh
from engine.quality import corner_angles, shape_quality
from engine.relax import node_stars
from engine.swap import _neighbours, regularise_valence, swap_diagonals

from ..conftest import DATA
from .random_meshes import meshes, random_mesh
from .regions import Rings, region_of, regions


def _undirected(edges: np.ndarray) -> set[tuple[int, int]]:
    return {(int(min(a, b)), int(max(a, b))) for a, b in edges}


def _sharp_corners(mesh: Mesh) -> dict[int, float]:
    """Boundary nodes whose domain angle is under 60 degrees: their angle (degrees)."""
    sums = np.bincount(mesh.triangles.ravel(), corner_angles(mesh.points, mesh.triangles).ravel())
    nodes = np.flatnonzero(mesh.boundary_nodes & (sums[: mesh.n_points] < 60.0))
    return {int(v): float(sums[v]) for v in nodes}


def _improving_flips(mesh: Mesh) -> list[tuple[int, int]]:
    """Interior edges whose flip would raise the worse quality of their pair (brute force),
    except those splitting a corner sharper than 60 degrees below min(corner, 30) and below
    the pair's smallest angle."""
    tri, pts = mesh.triangles, mesh.points
    _edges, count, edge_of = edge_table(tri)
    q = shape_quality(pts, tri)
    sharp = _sharp_corners(mesh)
    found = []
    for e in np.flatnonzero(count == 2):
        (t1, k1), (t2, k2) = np.argwhere(edge_of == e)
        c, a, b = tri[t1, k1], tri[t1, (k1 + 1) % 3], tri[t1, (k1 + 2) % 3]
        d = tri[t2, k2]
        flipped = np.array([[c, a, d], [d, b, c]])
        new = shape_quality(pts, flipped).min()
        old = min(q[t1], q[t2])
        if not (new > 0 and new > old * (1 + 1e-9)):
            continue
        before = corner_angles(pts, tri[[t1, t2]]).min()
        split = corner_angles(pts, flipped)  # c is corner 0 then 2, d corner 2 then 0
        pieces = {int(c): min(split[0, 0], split[1, 2]), int(d): min(split[0, 2], split[1, 0])}
        if any(
            v in sharp and piece < min(sharp[v], 30.0) and piece < before - 1e-9
            for v, piece in pieces.items()
        ):
            continue
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


def _corner_pair(corner: float, far: float) -> Mesh:
    """Two triangles: (0, 1, 2) with a ``corner``-degree apex at node 0 on unit legs, and
    (3, 2, 1) across side 1-2 whose angles there are ``far`` degrees; every node on the
    boundary, so node 0's domain angle is ``corner``."""
    half = np.radians(corner) / 2
    a, b = np.array([np.cos(half), -np.sin(half)]), np.array([np.cos(half), np.sin(half)])
    d = 0.5 * (a + b) + [np.sin(half) * np.tan(np.radians(far)), 0.0]
    return Mesh(np.array([[0.0, 0.0], a, b, d]), np.array([[0, 1, 2], [3, 2, 1]]))


@settings(max_examples=60, deadline=None)
@given(corner=st.floats(5.0, 59.0), far=st.floats(1.0, 80.0))
@example(corner=56.0, far=30.0)
def test_swapping_never_splits_a_sharp_corner_below_its_bound(corner: float, far: float) -> None:
    # Flipping 1-2 to 0-3 halves the corner and can still raise the worse shape quality: a
    # 56-degree corner with 30-degree angles across became two 28-degree pieces (quality 0.60
    # -> 0.72), under the bound min(corner, 30) the corner sets, which no smoother can lift.
    mesh = _corner_pair(corner, far)
    out = swap_diagonals(mesh)
    before = corner_angles(mesh.points, mesh.triangles).min()
    after = corner_angles(out.points, out.triangles).min()
    assert after >= min(min(corner, 30.0), before) - 1e-9
    assert (
        shape_quality(out.points, out.triangles).min()
        >= shape_quality(mesh.points, mesh.triangles).min()
    )


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


def _lattice(nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """Equilateral lattice on a parallelogram-free strip: rows alternate their offset, so the
    left end has 60 and 120 degree corners; every interior node has six triangles."""
    pts = [[i + 0.5 * (j % 2), j * np.sqrt(3) / 2] for j in range(ny + 1) for i in range(nx + 1)]
    tri = []
    for j in range(ny):
        for i in range(nx):
            a, b = j * (nx + 1) + i, j * (nx + 1) + i + 1
            c, d = a + nx + 1, b + nx + 1
            tri += [[a, b, c], [b, d, c]] if j % 2 == 0 else [[a, d, c], [a, b, d]]
    return np.array(pts), np.array(tri, dtype=np.int64)


def _flip_edge(pts: np.ndarray, tri: np.ndarray, p: int, q: int) -> None:
    t1, t2 = np.flatnonzero((tri == p).any(axis=1) & (tri == q).any(axis=1))
    r = next(v for v in tri[t1] if v not in (p, q))
    s = next(v for v in tri[t2] if v not in (p, q))
    for t, new in ((t1, [r, s, p]), (t2, [s, r, q])):
        (ax, ay), (bx, by), (cx, cy) = pts[new]
        tri[t] = new if (bx - ax) * (cy - ay) - (by - ay) * (cx - ax) > 0 else new[::-1]


def test_a_boundary_node_short_of_a_triangle_takes_one_from_its_neighbour() -> None:
    """Along a straight edge, a boundary node left with two triangles (90 degrees each) next to
    one with four (45 degrees each), and one 5-7 pair of interior nodes a row above: no flip
    lowers interior irregularity alone, and boundary nodes never move, so only counting the
    boundary's angles mends it (three triangles each, interior all six)."""
    nx = 8
    pts, tri = _lattice(nx, 6)
    _flip_edge(pts, tri, 3, nx + 1 + 3)  # bottom node 3 gives a triangle to 4: 5 and 7 above
    _flip_edge(pts, tri, nx + 1 + 2, 2 * (nx + 1) + 3)  # the 5-7 pair moves a row up
    mesh = Mesh(pts, tri)
    validate_mesh(mesh.points, mesh.triangles)
    count = np.bincount(tri.ravel(), minlength=len(pts))
    inner = ~mesh.boundary_nodes
    assert (count[3], count[4]) == (2, 4)
    assert sorted(count[inner][count[inner] != 6]) == [5, 7]
    out = regularise_valence(mesh)
    assert out is not None
    validate_mesh(out.points, out.triangles)
    count = np.bincount(out.triangles.ravel(), minlength=len(pts))
    assert np.all(count[1:nx] == 3)  # the bottom edge's nodes between its corners
    assert np.all(count[inner] == 6)
    np.testing.assert_array_equal(out.points[~inner], pts[~inner])


def test_swapping_does_not_modify_its_input() -> None:
    mesh = random_mesh(7)
    before = mesh.triangles.copy()
    swap_diagonals(mesh)
    np.testing.assert_array_equal(mesh.triangles, before)


def _irregularity(mesh: Mesh, domain_angle: np.ndarray) -> float:
    """Sum over nodes of (mean angle - 60 degrees)^2, from triangle counts alone."""
    count = np.bincount(mesh.triangles.ravel(), minlength=len(mesh.points))
    return float(((domain_angle / count - 60.0) ** 2).sum())


def _domain_angles(mesh: Mesh) -> np.ndarray:
    """360 degrees at interior nodes, the region's angle at boundary nodes."""
    t = mesh.triangles
    total = np.bincount(t.ravel(), corner_angles(mesh.points, t).ravel(), len(mesh.points))
    return np.where(mesh.boundary_nodes, total, 360.0)


@settings(max_examples=25, deadline=None)
@given(mesh=meshes())
def test_valence_flips_lower_irregularity_and_keep_the_mesh_valid(mesh: Mesh) -> None:
    swapped = swap_diagonals(mesh, relax=True)
    out = regularise_valence(swapped)
    if out is None:
        return
    validate_mesh(out.points, out.triangles)
    angles = _domain_angles(swapped)
    assert _irregularity(out, angles) < _irregularity(swapped, angles)
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
    # The boundary the stages carried over (keeps_boundary, with_points) is the one found anew.
    for snap in (result.initial, result.swapped, result.smoothed):
        fresh = Mesh(snap.mesh.points, snap.mesh.triangles)
        np.testing.assert_array_equal(snap.mesh.boundary_nodes, fresh.boundary_nodes)
        np.testing.assert_array_equal(snap.mesh.boundary_edges, fresh.boundary_edges)


def _sorted_neighbours(tri: np.ndarray) -> np.ndarray:
    """The triangle across each side by sorting the sides (what _neighbours computed before)."""
    _, _, edge_of = edge_table(tri)
    flat = edge_of.ravel()
    order = np.argsort(flat, kind="stable")
    nbr = np.full(flat.size, -1, dtype=np.int64)
    same = flat[order[1:]] == flat[order[:-1]]
    nbr[order[:-1][same]] = order[1:][same] // 3
    nbr[order[1:][same]] = order[:-1][same] // 3
    return nbr.reshape(-1, 3)


def _sorted_edge_table(tri: np.ndarray) -> tuple[np.ndarray, ...]:
    """edge_table by sorting the sides' codes (what it computed before)."""
    sides = np.stack([tri[:, [1, 2]], tri[:, [2, 0]], tri[:, [0, 1]]], axis=1).reshape(-1, 2)
    n = int(tri.max()) + 1
    codes = sides.min(axis=1) * n + sides.max(axis=1)
    unique, inverse, count = np.unique(codes, return_inverse=True, return_counts=True)
    return np.stack([unique // n, unique % n], axis=1), count, inverse.reshape(-1, 3)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), nodes=st.integers(3, 40))
def test_neighbours_and_stars_match_the_sorting_statements(seed: int, nodes: int) -> None:
    # Random corner triples: non-manifold edges and repeated corners included.
    rng = np.random.default_rng(seed)
    tri = rng.integers(0, nodes, (int(rng.integers(1, 3 * nodes)), 3))
    for got, want in zip(edge_table(tri), _sorted_edge_table(tri), strict=True):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(_neighbours(tri), _sorted_neighbours(tri))
    start, tri_of = node_stars(tri, nodes + 2)
    np.testing.assert_array_equal(corner_order(tri), np.argsort(tri.ravel(), kind="stable"))
    np.testing.assert_array_equal(tri_of, np.argsort(tri.ravel(), kind="stable") // 3)
    np.testing.assert_array_equal(np.diff(start), np.bincount(tri.ravel(), minlength=nodes + 2))
