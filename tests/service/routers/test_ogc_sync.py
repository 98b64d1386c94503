"""OGC synchronous execution: ``Prefer`` (RFC 7240), ``response`` and ``outputs``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import anyio
import httpx
import meshio
import pytest

from service.jobs.store import JobRecord, JobStatus
from service.jobs.task import Task
from service.sync import job_problem

from ..conftest import SQUARE, app_of, assert_problem, wait_for

pytestmark = pytest.mark.anyio

MESH = {"boundary": SQUARE, "size": 0.25, "smoothing": {"method": "none"}}


async def _execute(
    client: httpx.AsyncClient, body: dict[str, Any], prefer: str | None = None
) -> httpx.Response:
    headers = {"Prefer": prefer} if prefer else {}
    return await client.post("/processes/mesh/execution", json=body, headers=headers)


async def test_sync_execute_is_offered(client: httpx.AsyncClient) -> None:
    described = (await client.get("/processes/mesh")).json()
    assert "sync-execute" in described["jobControlOptions"]
    listed = (await client.get("/processes")).json()["processes"]
    assert all("sync-execute" in p["jobControlOptions"] for p in listed)


async def test_no_prefer_is_async_and_applies_nothing(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"inputs": MESH})
    assert r.status_code == 201, r.text
    assert "preference-applied" not in r.headers
    assert r.json()["status"] == "accepted"


async def test_respond_async_is_applied(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"inputs": MESH}, prefer="respond-async")
    assert r.status_code == 201, r.text
    assert r.headers["preference-applied"] == "respond-async"


async def test_wait_answers_the_document_of_outputs(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"inputs": MESH, "response": "document"}, prefer="wait=60")
    assert r.status_code == 200, r.text
    assert r.headers["preference-applied"] == "wait=60"
    assert r.headers["location"].startswith("http://testserver/jobs/")
    doc = r.json()
    assert set(doc) == {"mesh"}
    assert len(doc["mesh"]["triangles"]) > 0
    # the job is kept: its results are the same mesh
    job_id = r.headers["location"].rsplit("/", 1)[1]
    assert (await client.get(f"/jobs/{job_id}/results")).json() == doc["mesh"]


async def test_wait_is_capped_by_the_setting(make_client: Any) -> None:
    client = await make_client(max_sync_wait=5.0)
    r = await _execute(client, {"inputs": MESH}, prefer="wait=3600")
    assert r.headers["preference-applied"] == "wait=5"


async def test_raw_response_in_the_asked_format(client: httpx.AsyncClient) -> None:
    body = {
        "inputs": MESH,
        "response": "raw",
        "outputs": {"mesh": {"format": {"mediaType": "application/geo+json"}}},
    }
    r = await _execute(client, body, prefer="wait=60")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"].startswith("application/geo+json")
    assert r.json()["type"] == "FeatureCollection"


async def test_raw_response_default_is_the_mesh_document(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"inputs": MESH, "response": "raw"}, prefer="wait=60")
    assert r.status_code == 200, r.text
    assert "triangles" in r.json()


async def test_raw_vtu_reads_back(client: httpx.AsyncClient, tmp_path: Path) -> None:
    body = {
        "inputs": MESH,
        "response": "raw",
        "outputs": {"mesh": {"format": {"mediaType": "application/xml"}}},  # vtu's
    }
    r = await _execute(client, body, prefer="wait=60")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"].startswith("application/xml")
    path = tmp_path / "mesh.vtu"
    path.write_bytes(r.content)
    mesh = meshio.read(path)
    assert len(mesh.points) > 0


async def test_unknown_output_id_is_a_400(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"inputs": MESH, "outputs": {"nope": {}}})
    assert_problem(r, 400, "invalid-parameter")
    assert "nope" in r.json()["detail"]


async def test_unknown_output_media_type_is_a_400(client: httpx.AsyncClient) -> None:
    body = {"inputs": MESH, "outputs": {"mesh": {"format": {"mediaType": "text/x-nope"}}}}
    assert_problem(await _execute(client, body), 400, "invalid-parameter")


async def test_wait_running_out_answers_the_job(client: httpx.AsyncClient) -> None:
    r = await client.post(
        "/processes/sleep/execution",
        json={"inputs": {"seconds": 30}},
        headers={"Prefer": "respond-async, wait=1"},
    )
    assert r.status_code == 201, r.text
    assert r.headers["preference-applied"] == "wait=1"
    assert r.json()["status"] in {"accepted", "running"}
    await client.delete(f"/jobs/{r.json()['jobID']}")


async def _sync_failure(
    client: httpx.AsyncClient, process: str, inputs: dict[str, Any], status: int, kind: str
) -> dict[str, Any]:
    """Execute with ``Prefer: wait=60``: a problem of ``status`` and ``kind`` naming the job."""
    r = await client.post(
        f"/processes/{process}/execution", json={"inputs": inputs}, headers={"Prefer": "wait=60"}
    )
    doc = assert_problem(r, status, kind)
    assert r.headers["preference-applied"] == "wait=60"
    job_url = f"http://testserver/jobs/{doc['jobID']}"
    assert r.headers["location"] == job_url
    assert {"href": job_url, "rel": "status", "type": "application/json", "title": "the job"} in (
        doc["links"]
    )
    assert doc["detail"].startswith("the job failed") or status == 410
    job = await wait_for(client, doc["jobID"])
    assert job["status"] in {"failed", "dismissed"}
    if status != 410:  # the kind is kept with the job, set from how its run ended
        record = app_of(client).state.manager.store.get(doc["jobID"])
        assert record.failure == kind
    return doc


async def test_bad_input_found_late_within_the_wait_is_a_422(client: httpx.AsyncClient) -> None:
    doc = await _sync_failure(client, "fail", {}, 422, "invalid-input")
    assert doc["detail"] == "the job failed: bad input"


async def test_time_limit_within_the_wait_is_a_422(make_client: Any) -> None:
    client = await make_client(job_timeout=0.5, cancel_grace=0.5)
    doc = await _sync_failure(client, "hang", {"seconds": 30}, 422, "limit-exceeded")
    assert "time limit of 0.5 s" in doc["detail"]


async def test_a_crash_on_the_last_attempt_within_the_wait_is_a_500(make_client: Any) -> None:
    client = await make_client(max_attempts=1, backend="local")  # a crash needs a worker process
    doc = await _sync_failure(client, "crash", {}, 500, "job-crashed")
    assert "killed by SIGKILL (attempt 1 of 1)" in doc["detail"]


def _refuse(task: Task) -> None:
    raise MemoryError("no memory to hand the task over")


async def test_an_internal_failure_within_the_wait_is_a_500(client: httpx.AsyncClient) -> None:
    with pytest.MonkeyPatch.context() as patch:  # the backend cannot take the job
        patch.setattr(app_of(client).state.manager.backend, "submit", _refuse)
        doc = await _sync_failure(client, "sleep", {"seconds": 0}, 500, "internal-error")
    assert "could not be handed to a worker: MemoryError" in doc["detail"]


async def test_a_job_dismissed_within_the_wait_is_a_410(client: httpx.AsyncClient) -> None:
    async def dismiss_when_running() -> None:
        listed: list[dict[str, Any]] = []
        while not listed:
            listed = (await client.get("/jobs", params={"status": "running"})).json()["jobs"]
            await anyio.sleep(0.02)
        await client.delete(f"/jobs/{listed[0]['jobID']}")

    async with anyio.create_task_group() as tg:
        tg.start_soon(dismiss_when_running)
        await _sync_failure(client, "sleep", {"seconds": 30}, 410, "job-dismissed")


def _failed(message: str, failure: str = "") -> JobRecord:
    return JobRecord("j", "mesh", JobStatus.failed, 1.0, 2.0, message=message, failure=failure)


def test_the_kept_kind_names_the_problem_whatever_the_message_says() -> None:
    # A runner's own words that look like the service's: the kind decides, not the words.
    problem = job_problem("http://x", _failed("internal error: the ring is open", "invalid-input"))
    assert (problem.status, problem.kind) == (422, "invalid-input")
    problem = job_problem("http://x", _failed("the region is empty", "backend-unavailable"))
    assert (problem.status, problem.kind) == (503, "backend-unavailable")


@pytest.mark.parametrize(
    ("message", "status", "kind"),
    [
        ("stopped after exceeding the time limit of 2 s", 422, "limit-exceeded"),
        ("the worker process was killed by SIGKILL (attempt 3 of 3)", 500, "job-crashed"),
        ("internal error: ZeroDivisionError: division by zero", 500, "internal-error"),
        ("the boundary crosses itself", 422, "invalid-input"),
    ],
)
def test_a_job_stored_without_a_kind_is_named_by_its_message(
    message: str, status: int, kind: str
) -> None:
    problem = job_problem("http://x", _failed(message))
    assert (problem.status, problem.kind) == (status, kind)
