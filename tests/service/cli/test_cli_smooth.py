"""``evomesh smooth`` / ``evomesh quality`` / the smoothing flags of ``evomesh mesh``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from engine import validate_mesh
from service.cli import main

from ...engine.random_meshes import random_mesh

FAST = ["--population", "20", "--generations", "8", "--max-sweeps", "2"]


def _write(tmp_path: Path, doc: Any, name: str = "in.json") -> str:
    path = tmp_path / name
    path.write_text(json.dumps(doc) if not isinstance(doc, str) else doc)
    return str(path)


def _mesh_doc(seed: int = 1) -> dict[str, Any]:
    mesh = random_mesh(seed, affine=False)
    return {"points": mesh.points.tolist(), "triangles": mesh.triangles.tolist()}


@pytest.mark.parametrize("method", ["ga", "smart-laplacian", "laplacian", "none"])
def test_smooth_writes_a_valid_improved_mesh(
    tmp_path: Path, method: str, capsys: pytest.CaptureFixture[str]
) -> None:
    src = _mesh_doc()
    out = tmp_path / "out.json"
    assert main(["smooth", _write(tmp_path, src), "--method", method, *FAST, "-o", str(out)]) == 0
    assert "min quality" in capsys.readouterr().out
    doc = json.loads(out.read_text())
    mesh = validate_mesh(doc["points"], doc["triangles"])
    summary = doc["summary"]
    assert summary["smoothed"]["inverted"] == 0
    assert summary["parameters"]["smoothing"]["method"] == method
    assert summary["parameters"]["seed"] == 0
    if method != "none":
        assert len(summary["history"]) >= 1
        assert summary["smoothed"]["quality"]["min"] >= summary["initial"]["quality"]["min"]
    boundary = np.array(doc["point_data"]["boundary"], dtype=bool)
    np.testing.assert_array_equal(mesh.points[boundary], np.array(src["points"])[boundary])


def test_smooth_flags_reach_the_engine(tmp_path: Path) -> None:
    out = tmp_path / "out.json"
    flags = ["--no-swap", "--fitness", "worst", "--threshold", "0.9", "--seed", "7"]
    flags += ["--crossover-rate", "0.5", *FAST]
    args = ["smooth", _write(tmp_path, _mesh_doc()), *flags, "-o", str(out)]
    assert main(args) == 0
    summary = json.loads(out.read_text())["summary"]
    smoothing = summary["parameters"]["smoothing"]
    assert smoothing["fitness"] == "worst"
    assert smoothing["threshold"] == 0.9
    assert smoothing["crossover_rate"] == 0.5
    assert summary["parameters"]["swap"] is False
    assert summary["parameters"]["seed"] == 7


def test_same_seed_same_output(tmp_path: Path) -> None:
    src = _write(tmp_path, _mesh_doc(3))
    outs = []
    for k in range(2):
        out = tmp_path / f"o{k}.json"
        assert main(["smooth", src, *FAST, "--seed", "5", "-o", str(out)]) == 0
        outs.append(json.loads(out.read_text())["points"])
    assert outs[0] == outs[1]


def test_quality_prints_the_summary_and_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    src = _write(tmp_path, _mesh_doc())
    assert main(["quality", src]) == 0
    text = capsys.readouterr().out
    for word in ("triangles", "radius_ratio", "min_angle", "inverted", "fitness"):
        assert word in text
    assert main(["quality", src, "--json", "--fitness", "worst"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["summary"]["fitness"]["function"] == "worst"
    assert len(doc["point_data"]["fitness"]) == len(_mesh_doc()["points"])
    assert set(doc["cell_data"]) >= {"quality", "radius_ratio", "min_angle", "max_angle"}


BAD_MESHES = {
    "non-manifold": (
        {"points": [[0, 0], [1, 0], [0, 1], [0, -1], [1, 1]],
         "triangles": [[0, 1, 2], [1, 0, 3], [0, 1, 4]]},
        "non-manifold|same direction",
    ),
    "inverted": (
        {"points": [[0, 0], [1, 0], [0, 1], [1, 1]], "triangles": [[0, 1, 2], [1, 2, 3]]},
        "inverted",
    ),
    "index out of range": (
        {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 1, 3]]}, "outside",
    ),
    "nan": (
        '{"points": [[0, 0], [1, 0], [NaN, 1]], "triangles": [[0, 1, 2]]}',
        "non-finite|finite number",
    ),
    "overlapping": (  # a 3 x 3 grid and a triangle over its lower right half
        {"points": [[0, 0], [0.5, 0], [1, 0], [0, 0.5], [0.5, 0.5], [1, 0.5], [0, 1], [0.5, 1],
                    [1, 1]],
         "triangles": [[0, 1, 4], [1, 2, 5], [3, 4, 7], [4, 5, 8], [0, 4, 3], [1, 5, 4],
                       [3, 7, 6], [4, 8, 7], [0, 2, 8]]},
        "overlap",
    ),
    "missing triangles": ({"points": [[0, 0], [1, 0], [0, 1]]}, "triangles"),
    "not json": ("{points: oops", "Expecting"),
}  # fmt: skip


@pytest.mark.parametrize("command", ["smooth", "quality"])
@pytest.mark.parametrize("case", sorted(BAD_MESHES))
def test_bad_input_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str, case: str
) -> None:
    doc, pattern = BAD_MESHES[case]
    args = [command, _write(tmp_path, doc)]
    if command == "smooth":
        args += ["-o", str(tmp_path / "out.json")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("evomesh: error: ")
    assert err.count("\n") == 1
    assert any(p in err for p in pattern.split("|")), err
    assert not (tmp_path / "out.json").exists()


@pytest.mark.parametrize(
    "flags",
    [["--method", "magic"], ["--fitness", "best"], ["--population", "1"],
     ["--alpha", "0", "--beta", "0"], ["--threshold", "nan"]],
)  # fmt: skip
def test_bad_smoothing_flags_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], flags: list[str]
) -> None:
    out = tmp_path / "out.json"
    assert main(["smooth", _write(tmp_path, _mesh_doc()), *flags, "-o", str(out)]) == 2
    assert capsys.readouterr().err.startswith("evomesh: error: ")


def test_mesh_command_runs_the_full_pipeline_by_default(tmp_path: Path) -> None:
    region = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
    out = tmp_path / "mesh.json"
    assert main(["mesh", _write(tmp_path, region), "--size", "0.3", *FAST, "-o", str(out)]) == 0
    summary = json.loads(out.read_text())["summary"]
    assert summary["parameters"]["smoothing"]["method"] == "ga"
    assert summary["parameters"]["swap"] is True
    assert summary["smoothed"]["inverted"] == 0
    assert main(["mesh", _write(tmp_path, region), "--size", "0.3", "--smooth", "magic",
                 "-o", str(out)]) == 2  # fmt: skip
