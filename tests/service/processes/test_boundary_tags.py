"""A Feature's properties name its region and runs of its rings (service.boundary_tags), and the
mesh document of that Feature carries the tags."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import engine
from service.boundary_tags import region_name, tag_runs
from service.document import result_document
from service.geojson import BoundaryInputError, parse_region

OUTER = [[0, 0], [4, 0], [4, 1], [0, 1], [0, 0]]
HOLE = [[1, 0.4], [1.4, 0.4], [1.4, 0.6], [1, 0.6], [1, 0.4]]
FEATURE: dict[str, Any] = {
    "type": "Feature",
    "geometry": {"type": "Polygon", "coordinates": [OUTER, HOLE]},
    "properties": {
        "name": "channel",
        "tags": [
            {"name": "inlet", "ring": 0, "from": 3, "to": 0},
            {"name": "outlet", "from": 1, "to": 2},
            {"name": "pier", "ring": 1, "from": 0, "to": 0},
        ],
    },
}


def test_a_feature_s_runs_tag_its_mesh() -> None:
    parsed = parse_region(FEATURE)
    props = FEATURE["properties"]
    runs = tag_runs(props, [FEATURE["geometry"]["coordinates"]])
    params = engine.PipelineParams(
        engine.SizingParams(0.1), smoothing=engine.SmoothingParams("none")
    )
    result = engine.mesh_then_smooth(parsed.region, params)
    tagging = engine.Tagging(names=[region_name(props)], runs=runs)
    doc = result_document(
        result, tags=engine.tag_mesh(result.smoothed.mesh, parsed.region, tagging)
    )
    # The pier's run is its whole ring, so its default tag is used by no edge.
    assert doc["tags"] == {"channel/outer": 1, "inlet": 3, "outlet": 4, "pier": 5}
    pts = np.asarray(doc["points"])[np.asarray(doc["lines"])].mean(axis=1)
    tag = np.asarray(doc["line_data"]["tag"])
    assert np.array_equal(tag == 3, np.isclose(pts[:, 0], 0))
    assert np.array_equal(tag == 4, np.isclose(pts[:, 0], 4))
    inside = (pts[:, 0] > 0.9) & (pts[:, 0] < 1.5) & (pts[:, 1] > 0.3) & (pts[:, 1] < 0.7)
    assert np.array_equal(tag == 5, inside)


@pytest.mark.parametrize(
    ("tags", "pointer"),
    [
        ("inlet", "/properties/tags"),
        ([{"from": 0, "to": 1}], "/properties/tags/0"),
        ([{"name": "a", "from": 0, "to": 4}], "/properties/tags/0/to"),
        ([{"name": "a", "ring": 2, "from": 0, "to": 1}], "/properties/tags/0/ring"),
        ([{"name": "a", "from": True, "to": 1}], "/properties/tags/0/from"),
    ],
)
def test_bad_runs_point_at_the_entry(tags: Any, pointer: str) -> None:
    with pytest.raises(BoundaryInputError) as err:
        tag_runs({"tags": tags}, [[OUTER, HOLE]])
    assert err.value.pointer == pointer
