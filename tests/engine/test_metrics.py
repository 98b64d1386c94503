"""The metric registry drives the per-triangle figures and the summaries."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine
from engine.quality import Metric, TriangleGeometry, corner_angles

from .extra_metrics import edge_ratio as registered_edge_ratio
from .random_meshes import meshes


@pytest.fixture
def edge_ratio() -> Iterator[Metric]:
    with registered_edge_ratio() as metric:
        yield metric


def test_the_registry_lists_the_document_fields_in_order() -> None:
    assert list(engine.METRICS) == ["quality", "radius_ratio", "min_angle", "max_angle"]
    eq = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    q = engine.triangle_quality(engine.Mesh(eq, np.array([[0, 1, 2]])))
    for name, metric in engine.METRICS.items():  # an equilateral triangle is ideal
        assert q[name][0] == pytest.approx(metric.ideal)
    summary = engine.summarize(q)
    assert list(summary) == [
        "count",
        *engine.METRICS,
        "share_below_30deg",
        "share_quality_ge_0.91",
        "inverted",
    ]


@settings(max_examples=25, deadline=None)
@given(mesh=meshes())
def test_figures_match_their_definitions(mesh: engine.Mesh) -> None:
    q = engine.triangle_quality(mesh)
    angles = corner_angles(mesh.points, mesh.triangles)
    np.testing.assert_array_equal(q.min_angle, angles.min(axis=1))
    np.testing.assert_array_equal(q.max_angle, angles.max(axis=1))
    np.testing.assert_allclose(angles.sum(axis=1), 180.0)
    for name, metric in engine.METRICS.items():  # a metric called alone gives the same figures
        np.testing.assert_array_equal(metric(mesh.points, mesh.triangles), q[name])
    # Squared sides: four sqrt(3) times the area over them is the quality, by definition.
    s = sum(TriangleGeometry(mesh.points, mesh.triangles).squared_sides)
    np.testing.assert_allclose(q.quality, 4 * np.sqrt(3) * q.area / s, rtol=1e-12)
    assert (q.quality <= 1 + 1e-12).all()
    assert (q.radius_ratio <= 1 + 1e-12).all()


def _plain_geometry(points: np.ndarray, triangles: np.ndarray) -> list[np.ndarray]:
    """Squared sides, signed area and angles as plain numpy states them (the kernels' spec)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    sides = [((c - b) ** 2).sum(axis=1), ((a - c) ** 2).sum(axis=1), ((b - a) ** 2).sum(axis=1)]
    area = 0.5 * (
        (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    )
    corners, angles = (a, b, c), np.empty((len(triangles), 3))
    for k in range(3):
        u, v = corners[(k + 1) % 3] - corners[k], corners[(k + 2) % 3] - corners[k]
        cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
        angles[:, k] = np.degrees(np.arctan2(np.abs(cross), (u * v).sum(axis=1)))
    return [*sides, area, angles]


@settings(max_examples=25, deadline=None)
@given(mesh=meshes(), seed=st.integers(0, 2**32 - 1))
def test_compiled_geometry_is_bit_for_bit_numpys(mesh: engine.Mesh, seed: int) -> None:
    # Jittered, inverted, repeated-corner and zero-side triangles too: signs of zeros included.
    rng = np.random.default_rng(seed)
    points = np.concatenate([mesh.points, -mesh.points[:3], np.zeros((1, 2))])
    points[rng.random(len(points)) < 0.3] *= -1.0
    extra = rng.integers(0, len(points), (30, 3))
    extra[:5, 1] = extra[:5, 0]
    triangles = np.concatenate([mesh.triangles, extra])
    g = TriangleGeometry(points, triangles)
    for got, want in zip(
        [*g.squared_sides, g.area, g.angles], _plain_geometry(points, triangles), strict=True
    ):
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(np.signbit(got), np.signbit(want))


def test_a_registered_metric_reaches_figures_and_summaries(edge_ratio: Metric) -> None:
    right = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 1.0]])
    snap = engine.assess_mesh(engine.Mesh(right, np.array([[0, 1, 2]])))
    assert snap.quality["edge_ratio"][0] == pytest.approx(np.sqrt(5))
    assert snap.summary["edge_ratio"]["min"] == pytest.approx(np.sqrt(5))
