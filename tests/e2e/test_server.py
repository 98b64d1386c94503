"""End to end: a real ``evomesh serve`` on loopback, driven over HTTP."""

from __future__ import annotations

import contextlib
import os
import signal
import sqlite3
from collections.abc import Iterator
from pathlib import Path

import pytest

import engine
from tests.conftest import CASES, load_case

from .server import Server

pytestmark = pytest.mark.e2e

NONE = {"method": "none"}


@pytest.fixture
def servers(tmp_path: Path) -> Iterator[list[Server]]:
    started: list[Server] = []
    yield started
    for server in started:
        # Never leave a stopped (SIGSTOP) worker behind.
        for pid in server.workers():
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGCONT)
        server.stop()


def _start(servers: list[Server], data_dir: Path, workers: int = 1) -> Server:
    server = Server(data_dir, workers=workers)
    servers.append(server)
    return server


def test_public_cases_mesh_to_valid_meshes(servers: list[Server], tmp_path: Path) -> None:
    server = _start(servers, tmp_path / "data", workers=2)
    r = server.client.post(
        "/processes/mesh/execution",
        json={"inputs": {"boundary": load_case("l_shape"), "smoothing": NONE}},
    )
    assert r.status_code == 201, r.text
    assert r.headers["location"] == f"{server.url}/jobs/{r.json()['jobID']}"
    batch = server.client.post(
        "/batches",
        json={
            "type": "FeatureCollection",
            "features": [load_case(name) for name in CASES],
            "inputs": {"smoothing": NONE},
        },
    ).json()
    ids = [r.json()["jobID"], *(j["jobID"] for j in batch["jobs"])]
    for job_id in ids:
        assert server.wait(job_id)["status"] == "successful", server.log()
        doc = server.client.get(f"/jobs/{job_id}/results").json()
        mesh = engine.validate_mesh(doc["points"], doc["triangles"])
        assert mesh.n_triangles == len(doc["cell_data"]["quality"])
    assert server.client.get(f"/batches/{batch['batchID']}").json()["status"] == "successful"
    log = server.log()
    assert '"job_id"' in log  # structured logs carry the job id


def test_a_stopped_server_resumes_its_queue(servers: list[Server], tmp_path: Path) -> None:
    data = tmp_path / "data"
    server = _start(servers, data, workers=1)
    (worker,) = server.workers()
    os.kill(worker, signal.SIGSTOP)  # hold the queue: nothing can finish before the stop
    ids = []
    for i in range(8):
        body = {"inputs": {"boundary": load_case(CASES[i % len(CASES)]), "smoothing": NONE}}
        r = server.client.post("/processes/mesh/execution", json=body)
        assert r.status_code == 201
        ids.append(r.json()["jobID"])
    # uvicorn shuts down cleanly, then re-raises SIGTERM so the exit status tells why.
    assert server.stop() in (0, -signal.SIGTERM), server.log()
    assert "Application shutdown complete" in server.log()
    with sqlite3.connect(data / "jobs.sqlite3") as db:
        rows = dict(db.execute("SELECT id, status FROM jobs").fetchall())
    assert set(rows) == set(ids)
    assert set(rows.values()) == {"accepted"}  # the one that was running is queued again

    again = _start(servers, data, workers=2)
    for job_id in ids:
        doc = again.wait(job_id)
        assert doc["status"] == "successful", again.log()
        result = again.client.get(f"/jobs/{job_id}/results").json()
        engine.validate_mesh(result["points"], result["triangles"])
    assert again.client.get("/jobs").json()["numberMatched"] == len(ids)


def test_kill_9_a_worker_during_a_job(servers: list[Server], tmp_path: Path) -> None:
    server = _start(servers, tmp_path / "data", workers=1)
    (worker,) = server.workers()
    # Freeze the worker so the job is certainly in its hands when it dies, however fast it is.
    os.kill(worker, signal.SIGSTOP)
    body = {"inputs": {"boundary": load_case("annulus"), "smoothing": NONE}}
    job_id = server.client.post("/processes/mesh/execution", json=body).json()["jobID"]
    assert server.wait(job_id, statuses=("running",))["attempts"] == 1
    os.kill(worker, signal.SIGKILL)
    doc = server.wait(job_id)
    assert doc["status"] == "successful", (doc, server.log())
    assert doc["attempts"] == 2
    result = server.client.get(f"/jobs/{job_id}/results").json()
    engine.validate_mesh(result["points"], result["triangles"])
    replacement = server.workers()
    assert len(replacement) == 1
    assert replacement != [worker]
    assert server.client.get("/ready").json()["workers"]["alive"] == 1
    assert "SIGKILL" in server.log()
