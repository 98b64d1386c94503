"""OWSLib, OGC's reference Python client, drives a real ``evomesh serve`` on loopback:
discovery, synchronous and asynchronous execution, and the 3.0 OpenAPI document it looks for."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from typing import Any

import pytest
from owslib.ogcapi.processes import Processes

from .server import Server

pytestmark = pytest.mark.e2e

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
MESH = {"boundary": SQUARE, "size": 0.25, "smoothing": {"method": "none"}}


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    started = Server(tmp_path_factory.mktemp("owslib") / "data", workers=1)
    yield started
    started.stop()


@pytest.fixture
def client(server: Server) -> Processes:
    return Processes(server.url + "/")


def test_discovery(client: Processes) -> None:
    conformance = client.conformance()["conformsTo"]
    assert "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/oas30" in conformance
    api = client.api()  # found through the landing page's 3.0 service-desc link
    assert api["openapi"].startswith("3.0")
    ids = {p["id"] for p in client.processes()}
    assert {"mesh", "smooth", "quality"} <= ids
    mesh = client.process("mesh")
    assert "sync-execute" in mesh["jobControlOptions"]
    assert "boundary" in mesh["inputs"]
    assert "mesh" in mesh["outputs"]


def test_sync_execution(client: Processes) -> None:
    result: dict[str, Any] = client.execute("mesh", MESH)  # OWSLib: Prefer: respond-sync
    assert client.response_headers["Preference-Applied"] == "respond-sync"
    assert set(result) == {"mesh"}
    assert len(result["mesh"]["triangles"]) > 0


def test_async_execution(client: Processes, server: Server) -> None:
    job: dict[str, Any] = client.execute("mesh", MESH, async_=True)
    assert client.response_headers["Preference-Applied"] == "respond-async"
    assert job["status"] in {"accepted", "running", "successful"}
    location = client.response_headers["Location"]
    deadline = time.monotonic() + 120
    while (status := server.client.get(location).json())["status"] not in {"successful", "failed"}:
        assert time.monotonic() < deadline, status
        time.sleep(0.05)
    assert status["status"] == "successful"
    results = server.client.get(f"{location}/results").json()
    assert len(results["triangles"]) > 0


@pytest.fixture(scope="module")
def strict_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    """A server whose jobs may run 0.1 s: a mesh of about 70,000 triangles (a second's work)
    fails on the time limit."""
    started = Server(
        tmp_path_factory.mktemp("owslib-strict") / "data",
        workers=1,
        EVOMESH_JOB_TIMEOUT="0.1",
        EVOMESH_CANCEL_GRACE="1",
    )
    yield started
    started.stop()


def test_sync_execution_of_a_failing_job_is_its_problem(strict_server: Server) -> None:
    big = {**MESH, "size": 0.004}
    with pytest.raises(RuntimeError) as raised:  # OWSLib: the body of a non-2xx answer
        Processes(strict_server.url + "/").execute("mesh", big)
    problem = json.loads(str(raised.value))
    assert problem["status"] == 422
    assert problem["type"].endswith("limit-exceeded")
    assert "time limit of 0.1 s" in problem["detail"]
    job_url = f"{strict_server.url}/jobs/{problem['jobID']}"
    assert job_url in [link["href"] for link in problem["links"]]
    assert strict_server.client.get(job_url).json()["status"] == "failed"
    # the same over plain HTTP: the problem media type, and the job in Location
    r = strict_server.client.post(
        "/processes/mesh/execution", json={"inputs": big}, headers={"Prefer": "wait=60"}
    )
    assert r.status_code == 422, r.text
    assert r.headers["content-type"] == "application/problem+json"
    assert r.headers["location"] == f"{strict_server.url}/jobs/{r.json()['jobID']}"


def test_server_log_has_no_traceback(server: Server) -> None:
    assert "Traceback" not in server.log()
