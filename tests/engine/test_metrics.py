"""The metric registry drives the per-triangle figures and the summaries."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import given, settings

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


def test_a_registered_metric_reaches_figures_and_summaries(edge_ratio: Metric) -> None:
    right = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 1.0]])
    snap = engine.assess_mesh(engine.Mesh(right, np.array([[0, 1, 2]])))
    assert snap.quality["edge_ratio"][0] == pytest.approx(np.sqrt(5))
    assert snap.summary["edge_ratio"]["min"] == pytest.approx(np.sqrt(5))
