"""Constraints (engine.constraints): lines become chains of mesh edges, points mesh nodes; swapping
and smoothing hold them; bad constraints are located errors."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from engine import PipelineParams, Region, SizingParams, SmoothingParams, make_region, tag_mesh
from engine.constraints import (
    Constrained,
    InvalidConstraint,
    PinnedMesh,
    _close_pair,
    mesh_with_constraints,
)
from engine.mesh import edge_table, validate_mesh
from engine.refinement import Refinement

from .control_strategies import inside, valid_regions

SQUARE = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [[[0.6, 0.6], [0.8, 0.6], [0.7, 0.8]]])])


def _params(method: str = "laplacian", size: float = 0.1) -> PipelineParams:
    return PipelineParams(SizingParams(size), smoothing=SmoothingParams(method))


def line(*xy: list[float]) -> dict[str, Any]:
    return {"type": "LineString", "coordinates": [list(p) for p in xy]}


def point(x: float, y: float) -> dict[str, Any]:
    return {"type": "Point", "coordinates": [x, y]}


def _check(out: Constrained, region: Region, constraints: list[dict[str, Any]]) -> None:
    mesh = out.result.smoothed.mesh
    validate_mesh(mesh.points, mesh.triangles)
    assert np.isclose(mesh.areas.sum(), region.area)
    have = {tuple(e) for e in edge_table(mesh.triangles)[0].tolist()}
    assert all(tuple(sorted(e)) in have for e in out.edges.tolist())
    geoms = [shapely.geometry.shape(c) for c in constraints]
    lines = [g for g in geoms if "Line" in g.geom_type]
    length = np.linalg.norm(np.diff(mesh.points[out.edges], axis=1)[:, 0], axis=1).sum()
    assert np.isclose(length, shapely.union_all(lines).length if lines else 0.0)
    for g in geoms:
        for p in shapely.get_coordinates(g):
            assert np.hypot(*(mesh.points - p).T).min() < 1e-9
    first = out.result.initial.mesh
    assert np.array_equal(first.points[out.nodes], mesh.points[out.nodes])


@pytest.mark.parametrize(
    ("ring", "ends", "n"),
    [
        ([[0, 0], [1, 0], [1, 1], [0, 1]], [[0.5, 0.5], [0.5, 2.225073858507203e-309]], 1),
        (
            [[0, 0], [0, -1], [0, -2], [1, -2], [1, -1], [1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0]],
            [[0.0, 0.5], [0.9999999999999999, 0.0]],
            3,
        ),
    ],
)
def test_a_line_ending_a_hair_from_the_ring_is_only_itself(
    ring: list[list[float]], ends: list[list[float]], n: int
) -> None:
    """A line ending a rounding error from the ring (a spur of the noded ring along it, or
    the ring's halfway point at its end): no piece of ring is taken for a piece of the line
    (both found by the property test below)."""
    region = make_region([(ring, [])])
    cs = [line(*ends)]
    out = mesh_with_constraints(region, _params(size=0.5), cs)
    _check(out, region, cs)
    assert len(out.edges) == n


def test_a_dangling_line_and_points_are_edges_and_nodes() -> None:
    cs = [line([0.15, 0.2], [0.5, 0.45], [0.45, 0.8]), point(0.3, 0.7), point(0.85, 0.2)]
    out = mesh_with_constraints(SQUARE, _params("ga"), cs)
    _check(out, SQUARE, cs)
    assert set(out.edge_constraint.tolist()) == {0}
    assert len(out.edges) > 6  # split at the local size


def test_crossing_lines_meet_at_a_node_and_lines_may_reach_the_boundary() -> None:
    cs = [line([0.0, 0.3], [1.0, 0.35]), line([0.3, 0.05], [0.35, 0.95]), point(0.5, 0.5)]
    out = mesh_with_constraints(SQUARE, _params(), cs)
    _check(out, SQUARE, cs)
    crossing = shapely.geometry.shape(cs[0]).intersection(shapely.geometry.shape(cs[1]))
    mesh = out.result.smoothed.mesh
    assert np.hypot(*(mesh.points - [crossing.x, crossing.y]).T).min() < 1e-9
    assert set(out.edge_constraint.tolist()) == {0, 1}


@pytest.mark.parametrize(
    ("constraints", "index", "message"),
    [
        ([point(0.5, 0.5), line([0.5, 0.2], [1.4, 0.3])], 1, "constraint 1 leaves the region"),
        ([point(0.7, 0.7)], 0, "constraint 0 leaves the region"),  # in the hole
        ([point(0.5, 0.5), point(0.5, 0.5001)], 1, "nearly touches another"),
        ([point(0.0005, 0.5)], 0, "nearly touches the boundary"),
        ([{"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 1], [0, 0]]]}], 0, "must be"),
    ],
)
def test_bad_constraints_are_located_errors(
    constraints: list[dict[str, Any]], index: int, message: str
) -> None:
    with pytest.raises(InvalidConstraint, match=message) as err:
        mesh_with_constraints(SQUARE, _params(), constraints)
    assert err.value.index == index


@settings(
    max_examples=20,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
@given(case=valid_regions(), data=st.data())
def test_random_regions_refinements_and_constraints_stay_valid_and_keep_them(
    case: tuple[Region, float], data: st.DataObject
) -> None:
    region, size = case
    cs: list[dict[str, Any]] = []
    for _ in range(data.draw(st.integers(1, 3))):
        if data.draw(st.booleans()):
            cs.append(point(*data.draw(inside(region))))
        else:
            a, b = data.draw(inside(region)), data.draw(inside(region))
            assume(region.to_shapely().covers(shapely.LineString([a, b])))
            cs.append(line(a, b))
    refine = tuple(
        Refinement(
            point(*data.draw(inside(region))),
            data.draw(st.floats(0.1, 0.5)) * size,
            data.draw(st.none() | st.floats(1.05, 2.0)),
        )
        for _ in range(data.draw(st.integers(0, 2)))
    )
    params = PipelineParams(
        SizingParams(size, refinements=refine), smoothing=SmoothingParams("laplacian")
    )
    try:
        out = mesh_with_constraints(region, params, cs)
    except InvalidConstraint:  # nearly touching pieces: refused by design
        assume(False)
    _check(out, region, cs)


def test_constraint_lines_are_tagged_and_their_nodes_fixed() -> None:
    cs = [line([0.1, 0.1], [0.5, 0.3]), point(0.3, 0.8), line([0.2, 0.5], [0.4, 0.6])]
    out = mesh_with_constraints(SQUARE, _params(), cs)
    mesh = out.result.smoothed.mesh
    tags = tag_mesh(mesh, SQUARE, lines=out.lines(["fault"]), pinned=out.nodes)
    assert tags.tags == {"outer": 1, "hole-1": 2, "fault": 3, "constraint-2": 4}
    fault = tags.lines[tags.line_tag == 3]
    assert np.isclose(np.linalg.norm(np.diff(mesh.points[fault], axis=1)[:, 0], axis=1).sum(),
                      np.hypot(0.4, 0.2))  # fmt: skip
    at = int(np.argmin(np.hypot(*(mesh.points - [0.3, 0.8]).T)))
    assert tags.fixed[at]
    assert tags.fixed[out.nodes].all()


def test_a_pinned_mesh_with_moved_points_keeps_its_pins() -> None:
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.3, 0.3]])
    tris = np.array([[0, 1, 3], [1, 2, 3], [2, 0, 3]])
    pinned = np.array([False, False, False, True])
    moved = PinnedMesh(pts, tris, pinned).with_points(pts + 0.01)
    assert type(moved) is PinnedMesh
    assert moved.pinned is pinned
    assert moved.boundary_nodes.all()
    assert np.array_equal(moved.points, pts + 0.01)
    assert np.array_equal(moved.with_points(pts).boundary_nodes, moved.boundary_nodes)


@pytest.mark.parametrize("method", ["ga", "laplacian", "none"])
def test_every_stage_holds_the_constraint_nodes_whichever_smoother_ran(method: str) -> None:
    """Whether or not the smoother moved nodes, the smoothed mesh keeps its pins: they are
    among its held nodes (``boundary_nodes``, the document's ``point_data.boundary``), and
    its fitness summary is over the other nodes, as the earlier stages' are."""
    cs = [line([0.15, 0.2], [0.5, 0.45]), point(0.3, 0.7)]
    out = mesh_with_constraints(SQUARE, _params(method), cs, np.random.default_rng(0))
    result = out.result
    for snap in (result.initial, result.swapped, result.smoothed):
        held = snap.mesh.boundary_nodes
        assert held[out.nodes].all()
        assert snap.summary["fitness"]["mean"] == float(snap.fitness[~held].mean())
    moved = not np.array_equal(result.smoothed.mesh.points, result.swapped.mesh.points)
    assert moved == (method != "none")


def test_the_same_seed_gives_the_same_constrained_mesh() -> None:
    cs = [line([0.15, 0.2], [0.5, 0.45]), point(0.3, 0.7)]
    a, b = (
        mesh_with_constraints(SQUARE, _params("ga"), cs, np.random.default_rng(3)) for _ in range(2)
    )
    assert np.array_equal(a.result.smoothed.mesh.points, b.result.smoothed.mesh.points)
    assert np.array_equal(a.result.smoothed.mesh.triangles, b.result.smoothed.mesh.triangles)


def test_constrained_meshes_report_the_pipelines_timings_and_post_processing() -> None:
    """A constraint point at a corner changes nothing: the constrained path (swap, valence
    regularisation, smoothing) gives the plain pipeline's mesh, with the same timings keys."""
    from engine import mesh_then_smooth

    params = _params("laplacian", 0.08)
    plain = mesh_then_smooth(SQUARE, params, np.random.default_rng(0))
    out = mesh_with_constraints(SQUARE, params, [point(1, 1)], np.random.default_rng(0))
    assert list(out.result.timings) == list(plain.timings)
    assert out.result.timings["total"] >= out.result.timings["mesh"] > 0
    assert np.array_equal(out.result.smoothed.mesh.triangles, plain.smoothed.mesh.triangles)
    assert np.allclose(out.result.smoothed.mesh.points, plain.smoothed.mesh.points)


def _union_jack(n: int) -> tuple[np.ndarray, np.ndarray]:
    """An n x n grid of squares with alternating diagonals: nodes of valence 4 and 8, which
    valence regularisation flips."""
    xy = np.stack(np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0)), -1).reshape(-1, 2)
    tris = []
    for i, j in itertools.product(range(n), range(n)):
        a, b, c, d = (
            i * (n + 1) + j,
            i * (n + 1) + j + 1,
            (i + 1) * (n + 1) + j + 1,
            (i + 1) * (n + 1) + j,
        )
        tris += [[a, b, c], [a, c, d]] if (i + j) % 2 else [[a, b, d], [b, c, d]]
    return xy, np.array(tris)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**16), share=st.floats(0.05, 0.5))
def test_held_edges_and_nodes_survive_valence_regularisation(seed: int, share: float) -> None:
    """Any set of held interior edges stays in the mesh and any held node stays put through
    valence regularisation, and through the whole post-processing."""
    from engine.constraints import PinnedMesh, improve_held
    from engine.mesh import Mesh
    from engine.swap import regularise_valence

    rng = np.random.default_rng(seed)
    xy, tris = _union_jack(8)
    inside = (xy > 0).all(axis=1) & (xy < 8).all(axis=1)
    xy[inside] += rng.uniform(-0.15, 0.15, (int(inside.sum()), 2))  # so relaxing moves nodes
    mesh = Mesh(xy, tris)
    edges, count, _ = edge_table(mesh.triangles)
    inner = edges[count == 2]
    locked = inner[rng.random(len(inner)) < share]
    pinned = rng.random(mesh.n_points) < share
    regular = regularise_valence(PinnedMesh(mesh.points, mesh.triangles, pinned), locked)
    assert regular is not None
    result = improve_held(mesh, locked, pinned, _params("laplacian"), rng)
    for final in (regular, result.smoothed.mesh):
        have = {tuple(e) for e in edge_table(final.triangles)[0].tolist()}
        assert all(tuple(sorted(e)) in have for e in locked.tolist())
        assert np.array_equal(final.points[pinned], mesh.points[pinned])
        validate_mesh(final.points, final.triangles)
    assert set(result.timings) == {"boundary", "mesh", "swap", "smooth", "total"}


@settings(max_examples=200, deadline=None)
@given(
    st.integers(2, 60),
    st.floats(1e-3, 0.5),
    st.integers(0, 2**32 - 1),
    st.sampled_from([1.0, 1e-6, 1e6]),
)
def test_the_close_pair_grid_finds_a_pair_exactly_when_brute_force_does(
    n: int, near: float, seed: int, scale: float
) -> None:
    # Clustered points, so that both outcomes occur; at any scale of coordinates.
    rng = np.random.default_rng(seed)
    pts = scale * (rng.uniform(0, 1, (3, 2))[rng.integers(0, 3, n)] + rng.normal(0, 0.2, (n, 2)))
    d = np.hypot(*(pts[:, None] - pts[None]).transpose(2, 0, 1))
    i, j = np.triu_indices(n, 1)
    got = _close_pair(pts, near * scale)
    if not (d[i, j] <= near * scale).any():
        assert got is None
    else:
        assert got is not None
        assert got[0] < got[1]
        assert d[got] <= near * scale * (1 + 1e-12)


def test_the_close_pair_of_a_dense_line_is_its_first() -> None:
    # 200,000 points 1e-6 apart on a line: a pair within 0.01 for every point, found on the grid
    # without listing them (every pair within 0.01 from an R-tree is 4e9 pairs).
    pts = np.c_[np.arange(200_000) * 1e-6, np.zeros(200_000)]
    assert _close_pair(pts, 0.01) == (0, 1)
