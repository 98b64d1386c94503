"""``evomesh mesh`` with mesh control (issue 16): tags from the region file, ``--refine``,
``--refinements`` and ``--constraints``, through the engine locally and as service inputs."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest
import shapely

from service.cli import main
from service.cli.control_flags import add_control_flags, control_inputs

DUCT = {
    "type": "Feature",
    "properties": {"name": "duct", "tags": [{"name": "inlet", "from": 3, "to": 0}]},
    "geometry": {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [0, 1], [0, 0]]]},
}
DAM = {"type": "LineString", "coordinates": [[0.5, 0.2], [1.5, 0.8]]}


def test_local_mesh_tags_refines_and_constrains(tmp_path: Path) -> None:
    region = tmp_path / "duct.geojson"
    region.write_text(json.dumps(DUCT))
    dam = tmp_path / "dam.geojson"
    dam.write_text(json.dumps({"type": "Feature", "properties": {"name": "dam"}, "geometry": DAM}))
    more = tmp_path / "refinements.json"
    more.write_text(json.dumps([{"geometry": DAM, "size": 0.05}]))
    point = json.dumps({"geometry": {"type": "Point", "coordinates": [1.8, 0.2]}, "size": 0.02})
    out = tmp_path / "duct.json"
    args = ["mesh", str(region), "--size", "0.2", "--smooth", "none", "-o", str(out)]
    extra = ["--refine", point, "--refinements", str(more), "--constraints", str(dam)]
    assert main([*args, *extra]) == 0
    doc = json.loads(out.read_text())
    assert set(doc["tags"]) == {"duct/outer", "inlet", "dam"}
    assert doc["regions"] == {"duct": 1}
    pts = np.asarray(doc["points"])
    assert (np.hypot(*(pts - [1.8, 0.2]).T) < 0.03).sum() >= 5
    plain = tmp_path / "plain.json"
    assert main([*args[:-1], str(plain)]) == 0
    assert len(doc["triangles"]) > 2 * len(json.loads(plain.read_text())["triangles"])


def test_a_bad_refinement_is_a_user_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    region = tmp_path / "duct.geojson"
    region.write_text(json.dumps(DUCT))
    bad = json.dumps({"geometry": {"type": "Nowhere"}, "size": 0.1})
    args = ["mesh", str(region), "--size", "0.2", "--refine", bad, "-o", str(tmp_path / "x.json")]
    assert main(args) == 2
    assert "/refinements/0" in capsys.readouterr().err


def test_the_flags_become_service_inputs(tmp_path: Path) -> None:
    p = argparse.ArgumentParser()
    add_control_flags(p)
    dam = tmp_path / "dam.geojson"
    dam.write_text(json.dumps(DAM))
    point = '{"geometry": {"type": "Point", "coordinates": [1, 1]}, "size": 0.1}'
    args = p.parse_args(["--refine", point, "--constraints", str(dam)])
    assert control_inputs(args) == {"refinements": [json.loads(point)], "constraints": DAM}
    assert control_inputs(p.parse_args([])) == {}


def test_local_refinement_growth_and_lon_lat_control(tmp_path: Path) -> None:
    """``--refine`` takes a growth of its own; lon/lat regions take lon/lat refinements and
    constraints (sizes in metres) and the result comes back in lon/lat."""
    region = tmp_path / "box.geojson"
    box = [[14.0, 60.0], [14.2, 60.0], [14.2, 60.1], [14.0, 60.1], [14.0, 60.0]]
    region.write_text(json.dumps({"type": "Polygon", "coordinates": [box]}))
    line = {"type": "LineString", "coordinates": [[14.05, 60.05], [14.15, 60.05]]}
    dam = tmp_path / "dam.geojson"
    dam.write_text(json.dumps({"type": "Feature", "properties": {"name": "dam"}, "geometry": line}))
    counts = []
    for growth in ("", ', "growth": 1.05'):
        refine = (
            '{"geometry": {"type": "Point", "coordinates": [14.1, 60.02]}, "size": 150'
            + growth
            + "}"
        )
        out = tmp_path / f"box{len(counts)}.json"
        args = ["mesh", str(region), "--crs", "EPSG:4326", "--size", "1500", "--smooth", "none"]
        assert main([*args, "--refine", refine, "--constraints", str(dam), "-o", str(out)]) == 0
        doc = json.loads(out.read_text())
        counts.append(len(doc["triangles"]))
        pts = np.asarray(doc["points"])
        assert pts[:, 0].min() >= 14.0 - 1e-7
        assert pts[:, 0].max() <= 14.2 + 1e-7
        dam_edges = np.asarray(doc["lines"])[
            np.asarray(doc["line_data"]["tag"]) == doc["tags"]["dam"]
        ]
        assert np.allclose(pts[dam_edges][..., 1], 60.05, atol=1e-4)  # the line, in lon/lat
    assert counts[1] > 1.5 * counts[0]  # the slower-growing refinement reaches further


def test_local_mesh_of_subdomains_with_a_digitised_interface_and_a_fault(tmp_path: Path) -> None:
    """A FeatureCollection of two materials sharing a digitised edge, each with its own
    ``properties.h``, and a digitised fault crossing the edge, with ``--resample``: one
    conforming mesh through the API's own process (regions, the interface tag, the fault's
    edges, the thinned interface and fault within the tolerance, each polygon at its size)."""
    y = np.linspace(0.0, 1.0, 200)
    cut = np.c_[1.0 + 0.01 * np.sin(30 * y), y].tolist()
    left = [[0.0, 0.0], *cut, [0.0, 1.0], [0.0, 0.0]]
    right = [*cut, [2.0, 1.0], [2.0, 0.0], cut[0]]
    features = [
        {"type": "Feature", "properties": {"name": name, "h": h},
         "geometry": {"type": "Polygon", "coordinates": [ring]}}
        for name, h, ring in (("steel", 0.2, left), ("water", 0.08, right))
    ]  # fmt: skip
    region = tmp_path / "materials.geojson"
    region.write_text(json.dumps({"type": "FeatureCollection", "features": features}))
    t = np.linspace(0.0, 1.0, 300)[:, None]
    fault_xy = (1 - t) * [0.3, 0.2] + t * [1.7, 0.8] + 1e-3 * np.sin(50 * t)
    fault = tmp_path / "fault.geojson"
    geometry = {"type": "LineString", "coordinates": fault_xy.tolist()}
    fault.write_text(json.dumps({"type": "Feature", "properties": {"name": "fault"},
                                 "geometry": geometry}))  # fmt: skip
    out = tmp_path / "materials.json"
    args = ["mesh", str(region), "--size", "0.2", "--smooth", "laplacian", "--resample"]
    assert main([*args, "--constraints", str(fault), "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["regions"] == {"steel": 1, "water": 2}
    assert {"steel|water", "fault"} <= set(doc["tags"])
    pts, tris = np.asarray(doc["points"]), np.asarray(doc["triangles"])
    region_of = np.asarray(doc["cell_data"]["region"])
    a, b, c = (pts[tris[:, k]] for k in range(3))
    area = 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    density = [np.sum(region_of == k) / area[region_of == k].sum() for k in (1, 2)]
    assert density[1] > 1.5 * density[0]  # each material at its own size
    lines, tag = np.asarray(doc["lines"]), np.asarray(doc["line_data"]["tag"])
    tolerance = 0.1 * 0.08  # a tenth of the smallest size
    for name, drawn in (("steel|water", np.asarray(cut)), ("fault", fault_xy)):
        edges = lines[tag == doc["tags"][name]]
        chain = shapely.MultiLineString(list(pts[edges]))
        assert shapely.distance(chain, shapely.points(drawn)).max() <= tolerance + 1e-9
        assert len(np.unique(edges)) < len(drawn) / 2  # thinned, not every input vertex
    boundary = doc["summary"]["smoothed"]["boundary"]
    assert 0 < boundary["constraints_max_deviation"] <= tolerance
