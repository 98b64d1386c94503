"""``evomesh submit``, ``batch`` and ``jobs`` against a real ``evomesh serve`` on loopback.

The commands run as subprocesses without a terminal, so their progress is plain lines.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from PIL import Image

import engine
from tests.conftest import DATA, load_case

from .server import Server, free_port

pytestmark = pytest.mark.e2e

METHOD = "ga" if "ga" in engine.SMOOTHERS else "none"
FAST = [
    "--smooth",
    METHOD,
    "--input",
    "smoothing.generations=5",
    "--input",
    "smoothing.max_sweeps=2",
]
if METHOD == "none":
    FAST = ["--smooth", "none"]


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    s = Server(tmp_path_factory.mktemp("cli") / "data", workers=2)
    yield s
    s.stop()


def evomesh(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    exe = str(Path(sys.executable).parent / "evomesh")
    return subprocess.run(
        [exe, *args], input=stdin, capture_output=True, text=True, timeout=300, check=False
    )


def _one_line_error(proc: subprocess.CompletedProcess[str]) -> str:
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("evomesh: error: "), lines
    return lines[0]


def test_submit_wait_and_download(server: Server, tmp_path: Path) -> None:
    out = tmp_path / "l.json"
    proc = evomesh(
        "submit",
        str(DATA / "cases" / "l_shape.geojson"),
        "--url",
        server.url,
        *FAST,
        "--wait",
        "-o",
        str(out),
    )
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_bytes())
    mesh = engine.validate_mesh(doc["points"], doc["triangles"])
    assert doc["summary"]["parameters"]["sizing"]["size"] == 0.03  # the case's h
    assert f"{mesh.n_triangles:,} triangles" in proc.stdout
    assert f"-> {out}" in proc.stdout
    # Not a terminal: progress is plain lines (no bar, no carriage returns).
    assert "\r" not in proc.stderr
    assert "submitted to" in proc.stderr.splitlines()[0]

    picture = tmp_path / "l.png"
    proc = evomesh(
        "submit",
        "-",
        "--url",
        server.url,
        *FAST,
        "--size",
        "0.1",
        "-o",
        str(picture),
        stdin=json.dumps(load_case("l_shape")),
    )
    assert proc.returncode == 0, proc.stderr
    assert Image.open(io.BytesIO(picture.read_bytes())).format == "PNG"


def test_submit_without_waiting_prints_the_job_and_jobs_lists_it(server: Server) -> None:
    proc = evomesh(
        "submit",
        str(DATA / "cases" / "unit_square.geojson"),
        "--url",
        server.url,
        *FAST,
        "--seed",
        "7",
    )
    assert proc.returncode == 0, proc.stderr
    job_id = proc.stdout.strip()
    assert server.client.get(f"/jobs/{job_id}").json()["seed"] == 7
    assert server.wait(job_id)["status"] == "successful"
    listing = evomesh("jobs", "--url", server.url, "--status", "successful", "--limit", "100")
    assert listing.returncode == 0, listing.stderr
    header, *rows = listing.stdout.splitlines()
    assert header.split()[:4] == ["JOB", "PROCESS", "STATUS", "PROGRESS"]
    row = next(r for r in rows if r.startswith(job_id))
    assert row.split()[1:4] == ["mesh", "successful", "100%"]


def test_batch_a_folder_and_a_feature_collection(server: Server, tmp_path: Path) -> None:
    folder = tmp_path / "regions"
    folder.mkdir()
    for name in ("l_shape", "annulus", "plate_hole"):
        (folder / f"{name}.geojson").write_text(json.dumps(load_case(name)))
    out = tmp_path / "out"
    proc = evomesh(
        "batch",
        str(folder),
        "--url",
        server.url,
        "-o",
        str(out),
        *FAST,
        "--size",
        "0.08",
        "--format",
        "json,svg",
    )
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in out.iterdir()) == [
        f"{n}.{f}" for n in ("annulus", "l_shape", "plate_hole") for f in ("json", "svg")
    ]
    for name in ("annulus", "l_shape", "plate_hole"):
        doc = json.loads((out / f"{name}.json").read_text())
        assert doc["summary"]["parameters"]["sizing"]["size"] == 0.08  # shared inputs apply
        assert f"{name}: " in proc.stdout
    assert "3 of 3 regions meshed" in proc.stderr
    assert "3/3 done" in proc.stderr  # plain progress lines

    collection = {
        "type": "FeatureCollection",
        "features": [load_case("unit_square"), load_case("unit_square")],
    }
    source = tmp_path / "two.geojson"
    source.write_text(json.dumps(collection))
    proc = evomesh(
        "batch", str(source), "--url", server.url, "-o", str(out), *FAST, "--size", "0.2"
    )
    assert proc.returncode == 0, proc.stderr
    # Both features are named unit_square: the second result does not overwrite the first.
    assert (out / "unit_square.json").exists()
    assert (out / "unit_square-2.json").exists()


def test_errors_are_one_line_with_a_non_zero_status(server: Server, tmp_path: Path) -> None:
    bowtie = tmp_path / "bowtie.geojson"
    bowtie.write_text(
        json.dumps({"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]})
    )
    proc = evomesh("submit", str(bowtie), "--url", server.url, *FAST, "--size", "0.1")
    assert proc.returncode == 2
    line = _one_line_error(proc)
    assert "Unprocessable Entity: part 0 ring 0 (outer) intersects itself at (0.5, 0.5)" in line

    proc = evomesh(
        "submit",
        str(DATA / "cases" / "l_shape.geojson"),
        "--url",
        server.url,
        "--smooth",
        "no-such-smoother",
    )
    assert proc.returncode == 2
    assert "unknown smoothing method 'no-such-smoother'" in _one_line_error(proc)

    proc = evomesh("batch", str(tmp_path), "--url", server.url, "-o", str(tmp_path / "o"), *FAST)
    assert proc.returncode == 2  # the bowtie is in the folder: the batch is refused whole
    assert "intersects itself" in _one_line_error(proc)

    proc = evomesh("submit", str(bowtie), "--url", server.url, "-o", str(tmp_path / "x.txt"))
    assert proc.returncode == 2
    assert "unsupported output format '.txt'" in _one_line_error(proc)

    nobody = f"http://127.0.0.1:{free_port()}"
    proc = evomesh("jobs", "--url", nobody)
    assert proc.returncode == 1
    assert f"cannot reach {nobody}" in _one_line_error(proc)

    proc = evomesh("submit", str(tmp_path / "missing.geojson"), "--url", server.url)
    assert proc.returncode == 2
    assert "cannot read" in _one_line_error(proc)


def test_results_and_dismiss(server: Server, tmp_path: Path) -> None:
    square = str(DATA / "cases" / "unit_square.geojson")
    proc = evomesh("submit", square, "--url", server.url, "--smooth", "none", "--size", "0.2")
    job_id = proc.stdout.strip()
    assert server.wait(job_id)["status"] == "successful"

    out = tmp_path / "sq.msh"
    proc = evomesh("results", job_id, "--url", server.url, "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    assert f"job {job_id}: " in proc.stdout
    assert f"-> {out}" in proc.stdout
    doc = json.loads(evomesh("results", job_id, "--url", server.url, "-o", "-").stdout)
    quality = evomesh("quality", str(out), "--json")  # what was downloaded reads back
    assert json.loads(quality.stdout)["summary"]["count"] == len(doc["triangles"])

    options = ["--format", "png", "--option", "width=300", "--option", "height=200"]
    exe = str(Path(sys.executable).parent / "evomesh")
    png = subprocess.run(
        [exe, "results", job_id, "--url", server.url, *options, "-o", "-"],
        capture_output=True,
        timeout=300,
        check=True,
    )
    assert Image.open(io.BytesIO(png.stdout)).size == (300, 200)
    proc = evomesh("results", job_id, "--url", server.url, "-o", "x.png", "--option", "color=pink")
    assert proc.returncode == 2
    assert "unknown color 'pink'" in _one_line_error(proc)  # the service's own words

    proc = evomesh("dismiss", job_id, "--url", server.url)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"job {job_id}: dismissed"
    proc = evomesh("results", job_id, "--url", server.url, "-o", str(tmp_path / "gone.json"))
    assert proc.returncode == 2
    assert "the job was dismissed; it has no results" in _one_line_error(proc)
    assert not (tmp_path / "gone.json").exists()
    proc = evomesh("dismiss", "no-such-job", "--url", server.url)
    assert proc.returncode == 2
    assert "Not Found" in _one_line_error(proc)
