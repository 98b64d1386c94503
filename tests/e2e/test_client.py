"""The Python client (:mod:`service.client`) against a real ``evomesh serve`` on loopback."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path

import meshio
import pytest
from PIL import Image

import engine
from service.client import (
    Client,
    ConnectionFailed,
    JobFailed,
    ProblemError,
    Status,
    WaitTimeout,
)
from tests.conftest import DATA

from .server import Server, free_port

pytestmark = pytest.mark.e2e

FAST = {"method": "ga", "generations": 5, "max_sweeps": 2, "population": 10}
SQUARE = {"outer": [[0, 0], [1, 0], [1, 1], [0, 1]]}


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    s = Server(tmp_path_factory.mktemp("client") / "data", workers=1)
    yield s
    s.stop()


@pytest.fixture
def client(server: Server) -> Iterator[Client]:
    with Client(server.url, poll=0.05) as c:
        yield c


def test_mesh_wait_with_progress_and_download(client: Client, tmp_path: Path) -> None:
    job = client.mesh(DATA / "cases" / "l_shape.geojson", smoothing={**FAST, "seed": 5})
    seen: list[Status] = []
    final = job.wait(progress=seen.append, timeout=120)
    assert final.status == "successful"
    assert seen[-1] == final
    assert final.progress == 100
    progress = [s.progress for s in seen]
    assert progress == sorted(progress)  # each new status, in order
    assert len(set(seen)) == len(seen)  # and only changes

    doc = job.document()
    mesh = engine.validate_mesh(doc["points"], doc["triangles"])
    assert doc["summary"]["parameters"]["sizing"]["size"] == 0.03  # the case's h
    assert doc["summary"]["parameters"]["seed"] == 5

    data = job.result("msh", path=tmp_path / "l.msh")
    assert (tmp_path / "l.msh").read_bytes() == data
    assert len(meshio.read(tmp_path / "l.msh").get_cells_type("triangle")) == mesh.n_triangles

    png = job.result("png", color="min_angle", width=300, height=200)
    assert Image.open(io.BytesIO(png)).size == (300, 200)

    # The file just downloaded goes back as the input of the other processes.
    quality = client.quality(tmp_path / "l.msh")
    assert quality.wait(timeout=60).status == "successful"
    q = quality.document()
    assert q["summary"]["mesh"]["count"] == mesh.n_triangles
    smooth = client.smooth(doc, smoothing={"method": "laplacian"}, swap=False)
    smooth.wait(timeout=60)
    assert len(smooth.document()["triangles"]) == mesh.n_triangles


def test_refusals_carry_the_servers_problem(client: Client) -> None:
    bowtie = {"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]}
    with pytest.raises(ProblemError) as exc:
        client.mesh(bowtie, size=0.1)
    assert exc.value.status == 422
    assert exc.value.title == "Unprocessable Entity"
    assert "intersects itself" in exc.value.detail
    assert exc.value.pointer is not None
    assert exc.value.pointer.startswith("/inputs/boundary")

    with pytest.raises(ProblemError) as exc:
        client.mesh(SQUARE, size=-1)
    assert exc.value.status == 422
    assert exc.value.pointer == "/inputs/size"

    with pytest.raises(ProblemError) as exc:
        client.job("no-such-job").status()
    assert exc.value.status == 404
    assert exc.value.type.endswith("no-such-job")


def test_dismiss_a_running_job(client: Client) -> None:
    job = client.mesh(SQUARE, size=0.01, smoothing={"method": "ga", "generations": 100})
    with pytest.raises(WaitTimeout, match=f"job {job.id} is still"):
        job.wait(timeout=0)
    assert job.dismiss().status == "dismissed"
    with pytest.raises(JobFailed, match="was dismissed") as exc:
        job.wait(timeout=60)
    assert exc.value.status.status == "dismissed"
    assert job.wait(check=False).status == "dismissed"
    with pytest.raises(ProblemError) as problem:
        job.result()
    assert problem.value.status == 410


def test_batch_and_job_listing(client: Client) -> None:
    batch = client.batch(
        [SQUARE, {"boundary": SQUARE, "size": 0.5}], size=0.25, smoothing={"method": "none"}
    )
    assert len(batch.jobs) == 2
    seen: list[dict[str, object]] = []
    doc = batch.wait(progress=seen.append, timeout=120)
    assert doc["counts"]["successful"] == 2
    assert seen[-1] == doc
    sizes = [j.document()["summary"]["parameters"]["sizing"]["size"] for j in batch.jobs]
    assert sizes == [0.25, 0.5]
    listed = {s.job_id for s in client.jobs(status=["successful"], limit=100)}
    assert {j.id for j in batch.jobs} <= listed


def test_an_unreachable_service_is_a_connection_error() -> None:
    url = f"http://127.0.0.1:{free_port()}"
    with Client(url) as c, pytest.raises(ConnectionFailed, match=f"cannot reach {url}"):
        c.job("x").status()
