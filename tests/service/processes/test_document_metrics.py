"""The engine's metric registry drives the document's cell data and the picture colourings."""

from __future__ import annotations

import io
from collections.abc import Iterator

import numpy as np
import pytest
from PIL import Image

import engine
from engine.quality import Metric
from service.document import cell_data, result_document
from service.render import METRICS, PictureOptions, render_picture

from ...engine.extra_metrics import edge_ratio as registered_edge_ratio


@pytest.fixture
def edge_ratio() -> Iterator[Metric]:
    with registered_edge_ratio() as metric:
        yield metric


def _result() -> engine.Result:
    region = engine.make_region([([[0, 0], [2, 0], [2, 1], [0, 1]], [])])
    params = engine.PipelineParams(
        engine.SizingParams(0.5), smoothing=engine.SmoothingParams("none")
    )
    return engine.mesh_then_smooth(region, params, np.random.default_rng(1))


def test_document_fields_and_picture_colours_are_the_registry() -> None:
    doc = result_document(_result())
    assert list(doc["cell_data"]) == list(engine.METRICS)
    assert list(doc["initial"]["cell_data"]) == list(engine.METRICS)
    assert list(METRICS) == ["quality", "fitness", "radius_ratio", "min_angle", "max_angle"]
    for name, metric in engine.METRICS.items():
        assert (METRICS[name].label, METRICS[name].ideal) == (metric.label, metric.ideal)


def test_a_registered_metric_is_a_field_and_a_colour(edge_ratio: Metric) -> None:
    result = _result()
    doc = result_document(result)
    ratios = doc["cell_data"]["edge_ratio"]
    assert len(ratios) == result.smoothed.mesh.n_triangles
    assert min(ratios) >= 1.0
    assert cell_data(result.initial)["edge_ratio"] == doc["initial"]["cell_data"]["edge_ratio"]
    options = PictureOptions.from_query({"color": "edge_ratio", "width": "300", "height": "200"})
    png = render_picture(doc, "png", options)
    assert Image.open(io.BytesIO(png)).size == (300, 200)
