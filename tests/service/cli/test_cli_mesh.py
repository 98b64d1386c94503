"""``evomesh mesh``: the mesh document on success, one-line errors with exit code 2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from engine import validate_mesh
from service.cli import main

DATA = Path(__file__).resolve().parents[2] / "data" / "cases"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    exe = str(Path(sys.executable).parent / "evomesh")
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=300)


def test_mesh_writes_the_document_with_timings(tmp_path: Path) -> None:
    out = tmp_path / "l.json"
    assert main(["mesh", str(DATA / "l_shape.geojson"), "--smooth", "none", "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    mesh = validate_mesh(doc["points"], doc["triangles"])
    assert mesh.n_triangles == len(doc["cell_data"]["quality"])
    assert len(doc["point_data"]["fitness"]) == mesh.n_points
    timings = doc["summary"]["timings"]
    assert set(timings) >= {"boundary", "mesh", "swap", "smooth", "total"}
    assert timings["total"] >= timings["mesh"] > 0
    assert doc["summary"]["parameters"]["sizing"]["size"] == 0.03  # the case's h property
    assert doc["summary"]["parameters"]["seed"] == 0


def test_size_flag_overrides_h_and_growth_is_used(tmp_path: Path) -> None:
    out = tmp_path / "sq.json"
    args = ["mesh", str(DATA / "unit_square.geojson"), "--size", "0.1", "--growth", "1.3"]
    assert main([*args, "--smooth", "none", "-o", str(out)]) == 0
    params = json.loads(out.read_text())["summary"]["parameters"]["sizing"]
    assert params["size"] == 0.1
    assert params["growth"] == 1.3


def test_outer_holes_json_and_stdin(tmp_path: Path) -> None:
    region = {
        "outer": [[0, 0], [1, 0], [1, 1], [0, 1]],
        "holes": [[[0.4, 0.4], [0.6, 0.4], [0.5, 0.6]]],
    }
    out = tmp_path / "oh.json"
    exe = str(Path(sys.executable).parent / "evomesh")
    proc = subprocess.run(
        [exe, "mesh", "-", "--size", "0.1", "--smooth", "none", "-o", str(out)],
        input=json.dumps(region), capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert json.loads(out.read_text())["summary"]["smoothed"]["count"] > 50


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (
            '{"type": "Polygon", "coordinates": [[[0,0],[1,1],[1,0],[0,1],[0,0]]]}',
            "intersects itself",
        ),
        (
            '{"type": "LineString", "coordinates": [[0,0],[1,1]]}',
            "unsupported boundary type 'LineString'",
        ),
        ('{"type": "Polygon", "coordinates": [[[0,0],[1,0]]]}', "fewer than 3"),
        ("not json", "Expecting value"),
        (
            '{"type": "Polygon", "coordinates": [[[0,0],[1,0],[1,1],[0,0]]]}',
            "/size: size is required",
        ),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path: Path, content: str, message: str) -> None:
    src = tmp_path / "bad.json"
    src.write_text(content)
    proc = _run("mesh", str(src), "--smooth", "none", "-o", str(tmp_path / "o.json"))
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("evomesh: error:")
    assert message in lines[0]
    assert not (tmp_path / "o.json").exists()


def test_missing_file_and_bad_output_format(tmp_path: Path) -> None:
    proc = _run("mesh", str(tmp_path / "nope.geojson"), "--size", "0.1", "-o", "x.json")
    assert proc.returncode == 2
    assert "No such file" in proc.stderr
    proc = _run(
        "mesh", str(DATA / "l_shape.geojson"), "--smooth", "none", "-o", str(tmp_path / "x.xyz")
    )
    assert proc.returncode == 2
    assert "unsupported output format" in proc.stderr
