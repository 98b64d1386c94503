"""Node fitness: the numba kernels agree with the numpy statement of each definition."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings

from engine.fitness import FITNESS, FITNESS_CODES, REFERENCE, fitness_code, node_fitness
from engine.ga_kernels import evaluate, single_width
from engine.mesh import Mesh
from engine.star import (
    FITNESS_KINDS,
    MIN_QUALITY,
    build_stars,
    combine,
    star_fitness,
    star_min_quality,
)

from .random_meshes import meshes, random_mesh

EQUILATERAL = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])


def test_every_fitness_has_a_reference_and_a_kernel() -> None:
    assert set(FITNESS) == set(REFERENCE) == set(FITNESS_CODES)
    assert {"angle", "aspect", "combined", "worst", "capped"} == set(FITNESS)


@settings(max_examples=30, deadline=None)
@given(mesh=meshes())
def test_kernels_agree_with_the_numpy_reference(mesh: Mesh) -> None:
    for name in FITNESS:
        for alpha, beta in ((0.8, 0.2), (0.3, 1.7)):
            fast = node_fitness(mesh, name, alpha, beta)
            ref = REFERENCE[name](mesh, alpha, beta)
            np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-12, err_msg=name)
            assert np.all((fast >= 0.0) & (fast <= 1.0 + 1e-12))


def test_equilateral_triangle_scores_one_everywhere() -> None:
    mesh = Mesh(EQUILATERAL, np.array([[0, 1, 2]]))
    for name in FITNESS:
        np.testing.assert_allclose(node_fitness(mesh, name), 1.0, atol=1e-12)


def test_inverted_star_and_unused_node_score_zero() -> None:
    pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [5.0, 5.0]])
    mesh = Mesh(pts, np.array([[0, 1, 2], [1, 2, 3]]))  # the second triangle is clockwise
    for name in FITNESS:
        fit = node_fitness(mesh, name)
        assert fit[3] == 0.0
        assert fit[4] == 0.0
        assert fit[0] > 0.0
        np.testing.assert_allclose(fit, REFERENCE[name](mesh, 0.8, 0.2), atol=1e-12)


def test_capped_is_combined_capped_by_the_worst_triangle() -> None:
    mesh = random_mesh(3)
    worst, combined = node_fitness(mesh, "worst"), node_fitness(mesh, "combined")
    capped = node_fitness(mesh, "capped")
    np.testing.assert_allclose(capped, np.minimum(combined, worst + 0.05), atol=1e-15)
    assert np.any(capped < combined)
    assert np.any(capped == combined)


def test_unknown_fitness_names_the_choices() -> None:
    with pytest.raises(ValueError, match=r"unknown fitness 'best'.*combined"):
        fitness_code("best")
    with pytest.raises(ValueError, match="unknown fitness"):
        node_fitness(random_mesh(0), "best")


@pytest.mark.parametrize("name", sorted(FITNESS))
@pytest.mark.parametrize("offset", [0.0, 3.0e5])
def test_ga_guide_fitness_is_the_exact_fitness_to_1e6(name: str, offset: float) -> None:
    """The GA's fast evaluation (single precision, polynomial arctangent) may differ only in
    rounding, also far from the origin (projected map coordinates); a candidate within
    rounding of the admissibility bound may fall either way."""
    rng = np.random.default_rng(5)
    mesh = random_mesh(11)
    s = build_stars(mesh.triangles, mesh.n_points)
    pts = mesh.points + np.array([offset, -0.5 * offset])
    code = FITNESS_CODES[name]
    for node in np.flatnonzero(~mesh.boundary_nodes)[:8]:
        nb = s.neighbours(int(node))
        lo, hi = pts[nb].min(axis=0), pts[nb].max(axis=0)
        cand = rng.uniform(lo, hi, (400, 2))
        out, work = np.empty(400), np.empty((5, single_width(400)), dtype=np.float32)
        scale = 2.0 ** -np.frexp(float((hi - lo).max()))[1]
        box = np.array([lo[0], hi[0] - lo[0], lo[1], hi[1] - lo[1], scale])
        j0, j1 = s.ptr[node], s.ptr[node + 1]
        xs, ys = cand[:, 0].copy(), cand[:, 1].copy()
        evaluate(xs, ys, out, work, box, j0, j1, pts, s.opp_a, s.opp_b, code, 0.8, 0.2)
        for (x, y), got in zip(cand, out, strict=True):
            worst = star_min_quality(x, y, node, pts, s.ptr, s.opp_a, s.opp_b)
            exact = star_fitness(x, y, node, pts, s.ptr, s.opp_a, s.opp_b, code, 0.8, 0.2)
            # Single precision puts an error of about 1e-7 on each triangle's quality.
            if worst <= 0.5 * MIN_QUALITY:
                assert got == 0.0
            elif worst > 2.0 * MIN_QUALITY:
                assert got == pytest.approx(exact, abs=1e-6)


def test_the_fitness_table_is_the_one_source_of_names_and_codes() -> None:
    assert list(FITNESS_CODES) == [name for name, _ in FITNESS_KINDS]
    assert sorted(FITNESS_CODES.values()) == list(range(len(FITNESS_KINDS)))
    # combine() dispatches every code: each row's formula is a distinct function of its inputs
    values = {combine(code, 0.9, 0.6, 0.5, 0.8, 0.2) for code in FITNESS_CODES.values()}
    assert len(values) == len(FITNESS_KINDS)
    for name, uses_angle in FITNESS_KINDS:
        code = FITNESS_CODES[name]
        moved = combine(code, 0.9, 0.6, 0.9, 0.8, 0.2) != combine(code, 0.95, 0.6, 0.9, 0.8, 0.2)
        assert moved == uses_angle, name
