"""Tags and regions survive every format: the mesh document, VTU, MSH 4.1 and 2.2 (read back by
our reader and by meshio as a solver would), GeoJSON (written)."""

from __future__ import annotations

from typing import Any

import numpy as np
import orjson
import pytest

import engine
from service.document import result_document
from service.formats import FORMATS, StoredResult, WriteError

LEFT = [[0, 0], [1, 0], [1, 1], [0, 1]]
RIGHT = [[2, 0], [3, 0], [3, 1], [2, 1]]
HOLE = [[2.4, 0.4], [2.6, 0.4], [2.5, 0.6]]


def _document() -> dict[str, Any]:
    parts = [(LEFT, []), (RIGHT, [HOLE])]
    region = engine.make_region(parts)
    params = engine.PipelineParams(
        engine.SizingParams(0.2), smoothing=engine.SmoothingParams("none")
    )
    result = engine.mesh_then_smooth(region, params)
    tagging = engine.Tagging(
        names=["steel", "water"], runs=(engine.TagRun("inlet", [[0, 0], [0, 1]]),)
    )
    return result_document(result, tags=engine.tag_mesh(result.smoothed.mesh, region, tagging))


DOC = _document()


def _tagged_edges(doc: dict[str, Any]) -> set[tuple[tuple[float, ...], tuple[float, ...], str]]:
    """Each tagged line as (its two end points, sorted) and its tag's name."""
    pts = np.asarray(doc["points"])
    names = {v: k for k, v in doc["tags"].items()}
    out = set()
    for (i, j), t in zip(doc["lines"], doc["line_data"]["tag"], strict=True):
        a, b = sorted([tuple(pts[i].tolist()), tuple(pts[j].tolist())])
        out.add((a, b, names[t]))
    return out


def _triangle_regions(doc: dict[str, Any]) -> dict[tuple[float, ...], str]:
    pts = np.asarray(doc["points"])
    names = {v: k for k, v in doc["regions"].items()}
    centroids = pts[np.asarray(doc["triangles"])].mean(axis=1).round(12)
    return {
        tuple(c.tolist()): names[r]
        for c, r in zip(centroids, doc["cell_data"]["region"], strict=True)
    }


def test_the_document_holds_tags_regions_and_fixed_nodes() -> None:
    assert DOC["tags"] == {"steel/outer": 1, "water/outer": 2, "water/hole-1": 3, "inlet": 4}
    assert DOC["regions"] == {"steel": 1, "water": 2}
    assert len(DOC["lines"]) == len(DOC["line_data"]["tag"]) > 0
    assert set(DOC["cell_data"]["region"]) == {1, 2}
    assert DOC["point_data"]["fixed"] == DOC["point_data"]["boundary"]
    x = np.asarray(DOC["points"])[np.asarray(DOC["lines"])].mean(axis=1)[:, 0]
    assert {n for *_, n in _tagged_edges(DOC) if n == "inlet"} == {"inlet"}
    assert np.all(np.isclose(x, 0) == (np.asarray(DOC["line_data"]["tag"]) == 4))


@pytest.mark.parametrize(
    ("fmt", "options"), [("json", {}), ("msh", {}), ("msh", {"version": "2.2"})]
)
def test_named_formats_round_trip_tags_and_regions(fmt: str, options: dict[str, str]) -> None:
    back = FORMATS[fmt].read(FORMATS[fmt].render(StoredResult(doc=DOC), options))
    assert back["tags"] == DOC["tags"]
    assert back["regions"] == DOC["regions"]
    assert _tagged_edges(back) == _tagged_edges(DOC)
    assert _triangle_regions(back) == _triangle_regions(DOC)


def test_vtu_round_trips_tag_and_region_ids() -> None:
    back = FORMATS["vtu"].read(FORMATS["vtu"].render(StoredResult(doc=DOC), {}))
    assert back["triangles"] == DOC["triangles"]
    assert back["cell_data"]["region"] == DOC["cell_data"]["region"]
    assert back["lines"] == DOC["lines"]
    assert back["line_data"]["tag"] == DOC["line_data"]["tag"]
    assert back["cell_data"]["quality"] == DOC["cell_data"]["quality"]


@pytest.mark.parametrize("version", ["4.1", "2.2"])
def test_meshio_finds_the_physical_groups_of_msh(tmp_path: Any, version: str) -> None:
    import meshio

    path = tmp_path / "mesh.msh"
    path.write_bytes(FORMATS["msh"].render(StoredResult(doc=DOC), {"version": version}))
    mesh = meshio.read(path)
    assert {k: v.tolist() for k, v in mesh.field_data.items()} == {
        "steel/outer": [1, 1], "water/outer": [2, 1], "water/hole-1": [3, 1], "inlet": [4, 1],
        "steel": [1, 2], "water": [2, 2],
    }  # fmt: skip
    lines = mesh.get_cells_type("line")
    physical = mesh.get_cell_data("gmsh:physical", "line")
    assert sorted(np.bincount(physical).tolist()) == sorted(
        np.bincount(DOC["line_data"]["tag"]).tolist()
    )
    assert len(lines) == len(DOC["lines"])
    if version == "4.1":  # meshio builds cell sets from 4.1's entities
        sets = mesh.cell_sets_dict
        assert len(sets["inlet"]["line"]) == DOC["line_data"]["tag"].count(4)
        assert len(sets["water"]["triangle"]) == DOC["cell_data"]["region"].count(2)


def test_msh_refuses_an_unknown_version() -> None:
    with pytest.raises(WriteError, match=r"unknown MSH version '3\.0'") as err:
        FORMATS["msh"].render(StoredResult(doc=DOC), {"version": "3.0"})
    assert err.value.parameter == "version"


def test_geojson_carries_regions_and_tagged_lines() -> None:
    geo = orjson.loads(FORMATS["geojson"].render(StoredResult(doc=DOC), {}))
    polys = [f for f in geo["features"] if f["geometry"]["type"] == "Polygon"]
    lines = [f for f in geo["features"] if f["geometry"]["type"] == "LineString"]
    assert [f["properties"]["region"] for f in polys] == DOC["cell_data"]["region"]
    assert {f["properties"]["region_name"] for f in polys} == {"steel", "water"}
    assert len(lines) == len(DOC["lines"])
    found = {
        (*sorted(tuple(c) for c in f["geometry"]["coordinates"]), f["properties"]["tag_name"])
        for f in lines
    }
    assert found == _tagged_edges(DOC)


@pytest.mark.parametrize("fmt", ["png", "svg"])
def test_pictures_colour_by_region_with_a_legend(fmt: str) -> None:
    picture = FORMATS[fmt].render(StoredResult(doc=DOC), {"color": "region"})
    plain = FORMATS[fmt].render(StoredResult(doc=DOC), {})
    assert picture != plain
    if fmt == "svg":  # text is drawn as paths: the legend's entries are labelled groups
        assert picture.count(b'<g id="legend') == 1


def test_colour_by_region_needs_regions() -> None:
    doc = {k: v for k, v in DOC.items() if k not in ("regions", "lines")}
    doc["cell_data"] = {k: v for k, v in DOC["cell_data"].items() if k != "region"}
    with pytest.raises(WriteError, match="no regions") as err:
        FORMATS["png"].render(StoredResult(doc=doc), {"color": "region"})
    assert err.value.parameter == "color"
