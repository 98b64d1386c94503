"""The smoother registry: every smoother keeps the mesh valid; the pipeline reports each stage."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine
from engine.mesh import Mesh, validate_mesh
from engine.params import SELECTIONS, SmoothingParams
from engine.smoothing import SMOOTHERS, smooth_points
from engine.star import build_stars, star_min_qualities
from engine.warm import compiled_kernels

from .random_meshes import meshes, random_mesh


def _quiet(stage: str, fraction: float) -> None:
    del stage, fraction


def _never() -> bool:
    return False


def _params(method: str) -> SmoothingParams:
    return SmoothingParams(method=method, population=24, generations=12, max_sweeps=3)


def _worst(mesh: Mesh) -> float:
    s = build_stars(mesh.triangles, mesh.n_points)
    nodes = np.arange(mesh.n_points, dtype=np.int64)
    return float(star_min_qualities(nodes, mesh.points, s.ptr, s.opp_a, s.opp_b).min())


def test_registry_holds_the_documented_smoothers() -> None:
    assert set(SMOOTHERS) == {"none", "laplacian", "smart-laplacian", "ga"}
    with pytest.raises(ValueError, match="unknown smoothing method 'magic'"):
        smooth_points(random_mesh(0), SmoothingParams("magic"), np.random.default_rng(0),
                      _quiet, _never)  # fmt: skip


@settings(max_examples=40, deadline=None)
@given(mesh=meshes(), method=st.sampled_from(sorted(SMOOTHERS)))
def test_every_smoother_keeps_the_mesh_valid(mesh: Mesh, method: str) -> None:
    out = smooth_points(mesh, _params(method), np.random.default_rng(0), _quiet, _never)
    moved = mesh.with_points(out.points)
    validate_mesh(moved.points, moved.triangles)
    boundary = mesh.boundary_nodes
    np.testing.assert_array_equal(moved.points[boundary], mesh.points[boundary])
    assert np.isclose(moved.areas.sum(), mesh.areas.sum(), rtol=1e-12)
    assert out.points is not mesh.points
    if method in ("smart-laplacian", "ga"):
        assert _worst(moved) >= _worst(mesh)


def test_laplacian_history_and_early_stop() -> None:
    mesh = random_mesh(2, affine=False)
    params = SmoothingParams(method="laplacian", iterations=500)
    out = smooth_points(mesh, params, np.random.default_rng(0), _quiet, _never)
    assert 1 <= len(out.history) < 500  # stops once no node moves
    assert out.history[-1].nodes_moved == 0
    assert all(h.nodes_evolved == int((~mesh.boundary_nodes).sum()) for h in out.history)


def test_laplacian_is_cancellable() -> None:
    with pytest.raises(engine.Cancelled):
        smooth_points(random_mesh(2), SmoothingParams("smart-laplacian"),
                      np.random.default_rng(0), _quiet, lambda: True)  # fmt: skip


@settings(max_examples=10, deadline=None)
@given(mesh=meshes(), swap=st.booleans())
def test_smooth_mesh_reports_every_stage(mesh: Mesh, swap: bool) -> None:
    params = _params("ga")
    result = engine.smooth_mesh(mesh, params, swap=swap, rng=np.random.default_rng(1))
    final = result.smoothed
    validate_mesh(final.mesh.points, final.mesh.triangles)
    assert final.summary["inverted"] == 0
    np.testing.assert_array_equal(final.fitness, engine.node_fitness(final.mesh))
    assert final.summary["quality"]["min"] >= result.swapped.summary["quality"]["min"] - 1e-12
    initial_min = result.initial.summary["quality"]["min"]
    assert result.swapped.summary["quality"]["min"] >= initial_min - 1e-12
    assert (len(result.history) >= 1) == bool((~mesh.boundary_nodes).any())
    assert set(result.timings) >= {"swap", "smooth", "total"}


@pytest.mark.parametrize(
    ("field", "value"),
    [("population", 1), ("generations", 0), ("crossover_rate", 1.5), ("mutation_rate", -0.1),
     ("max_sweeps", 0), ("iterations", 0), ("tolerance", -1.0), ("alpha", -1.0),
     ("threshold", float("nan")), ("selection", "worst"), ("poor_quality", 1.5)],
)  # fmt: skip
def test_parameters_out_of_range_are_refused(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field.split("_")[0]):
        SmoothingParams(**{field: value})


def test_zero_weights_are_refused() -> None:
    with pytest.raises(ValueError, match="alpha and beta"):
        SmoothingParams(alpha=0.0, beta=0.0)


def test_warmup_compiles_every_kernel_a_job_calls() -> None:
    compiled = engine.warmup()
    counts = compiled_kernels()
    assert compiled == tuple(sorted(name for name, n in counts.items() if n))
    ga = {f"engine.ga_kernels.{k}" for k in ("ga_init", "ga_step", "accept_moves")}
    assert ga | {"engine.front.driver._run", "engine.star.all_fitness"} <= set(compiled)
    # The splits at sharp corners, which the first job with one would otherwise compile.
    splits = {"engine.spanning._place", "engine.sides._search_line"}
    assert splits | {"engine.sides._place_on_two_sides"} <= set(compiled)
    # Jobs on another region, with every smoother and selection, compile nothing more.
    region = engine.make_region([([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], [])])
    for method in SMOOTHERS:
        for selection in SELECTIONS:
            smoothing = SmoothingParams(method=method, population=10, generations=3,
                                        max_sweeps=2, selection=selection)  # fmt: skip
            params = engine.PipelineParams(engine.SizingParams(0.15), smoothing=smoothing)
            result = engine.mesh_then_smooth(region, params, np.random.default_rng(1))
    # A smooth or quality job's input check: its pieces (engine.mesh._union_find) included.
    validate_mesh(result.smoothed.mesh.points, result.smoothed.mesh.triangles)
    assert "engine.mesh._union_find" in compiled
    # A job with constraints: its local searches (engine.repair._holding, ...) included.
    line = {"type": "LineString", "coordinates": [[0.2, 0.3], [1.7, 0.4]]}
    engine.mesh_with_constraints(region, engine.PipelineParams(engine.SizingParams(0.15)), [line])
    assert "engine.repair._holding" in compiled
    assert compiled_kernels() == counts
