"""``evomesh mesh`` with mesh control (issue 16): tags from the region file, ``--refine``,
``--refinements`` and ``--constraints``, through the engine locally and as service inputs."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

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
