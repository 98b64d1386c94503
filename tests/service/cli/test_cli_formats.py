"""The command line reads and writes every format of the table: ``-o out.vtu``, ``smooth in.msh``,
``-o -`` to standard output, and no traceback when the reader of a pipe goes away."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

from service.cli import main

from ..formats.format_catalogue import CATALOGUE

DATA = Path(__file__).resolve().parents[2] / "data" / "cases"
FAST = ["--generations", "3", "--max-sweeps", "1", "--population", "10"]


def _evomesh() -> str:
    return str(Path(sys.executable).parent / "evomesh")


@pytest.mark.parametrize("suffix", [".vtu", ".msh"])
def test_mesh_writes_meshio_formats_that_smooth_and_quality_read(
    tmp_path: Path, suffix: str, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / f"l{suffix}"
    assert main(["mesh", str(DATA / "l_shape.geojson"), "--smooth", "none", "-o", str(out)]) == 0
    written = meshio.read(out)
    assert written.get_cells_type("triangle").shape[1] == 3
    assert set(written.cell_data) >= {"quality", "min_angle"}
    capsys.readouterr()

    assert main(["quality", str(out), "--json"]) == 0
    quality = json.loads(capsys.readouterr().out)
    assert quality["summary"]["count"] == len(written.get_cells_type("triangle"))
    np.testing.assert_allclose(quality["cell_data"]["quality"], written.cell_data["quality"][0])

    smoothed = tmp_path / "s.json"
    assert main(["smooth", str(out), "--method", "laplacian", "-o", str(smoothed)]) == 0
    doc = json.loads(smoothed.read_text())
    assert len(doc["triangles"]) == len(written.get_cells_type("triangle"))
    initial = doc["summary"]["initial"]["quality"]["min"]  # the mesh as read
    assert initial == pytest.approx(float(np.min(written.cell_data["quality"][0])), abs=1e-12)


def test_smooth_writes_any_format_and_reads_by_flag(tmp_path: Path) -> None:
    src = tmp_path / "in.data"  # no telling extension: --input-format says what it is
    src.write_text(json.dumps(CATALOGUE["random, holes"]))
    out = tmp_path / "out.geojson"
    args = ["smooth", str(src), "--input-format", "json", "--method", "ga", *FAST, "-o", str(out)]
    assert main(args) == 0
    features = json.loads(out.read_text())["features"]
    assert len(features) == len(CATALOGUE["random, holes"]["triangles"])


def test_output_dash_writes_the_document_to_stdout(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["mesh", str(DATA / "unit_square.geojson"), "--size", "0.25", "--smooth", "none"]
    assert main([*args, "-o", "-"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    assert len(doc["triangles"]) == doc["summary"]["smoothed"]["count"]
    assert "-> -" in captured.err  # the summary line keeps out of the data


def test_output_dash_with_format(capsysbinary: pytest.CaptureFixture[bytes]) -> None:
    args = ["mesh", str(DATA / "unit_square.geojson"), "--size", "0.25", "--smooth", "none"]
    assert main([*args, "-o", "-", "--format", "png"]) == 0
    assert capsysbinary.readouterr().out.startswith(b"\x89PNG\r\n\x1a\n")


def test_unknown_extension_is_one_line_and_exit_2(tmp_path: Path) -> None:
    args = [_evomesh(), "mesh", str(DATA / "unit_square.geojson"), "-o", str(tmp_path / "m.vtk")]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "evomesh: error: unsupported output format '.vtk'; "
        "use one of .geojson .json .msh .png .svg .vtu"
    ]
    assert not (tmp_path / "m.vtk").exists()


def test_an_unreadable_mesh_file_is_one_line_and_exit_2(tmp_path: Path) -> None:
    bad = tmp_path / "bad.msh"
    bad.write_bytes(b"$MeshFormat\nnonsense\n")
    proc = subprocess.run(
        [_evomesh(), "quality", str(bad)], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("evomesh: error: not a gmsh file"), lines


def test_a_closed_pipe_is_not_a_traceback(tmp_path: Path) -> None:
    src = tmp_path / "m.json"
    src.write_text(json.dumps(CATALOGUE["random, holes"]))
    read, write = os.pipe()
    os.close(read)  # the reader is gone before anything is written (as `| head` after its line)
    try:
        proc = subprocess.run(
            [_evomesh(), "quality", str(src), "--json"],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            timeout=300,
        )
    finally:
        os.close(write)
    assert proc.stderr == ""
    assert proc.returncode == 1
