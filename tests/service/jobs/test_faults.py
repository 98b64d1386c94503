"""Faults: crashed workers, time-outs, a stopped service, retention (on worker processes)."""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path
from typing import Any

import anyio
import httpx
import pytest

from service.jobs.sqlite import SqliteJobStore
from service.jobs.store import JobStatus, NewJob
from service.logs import JsonFormatter

from ..conftest import SQUARE, ClientFactory, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio


@pytest.fixture
def make_client(make_client: ClientFactory) -> ClientFactory:
    """Workers are killed, time out and are stopped here: the local backend's processes."""

    async def factory(**overrides: Any) -> httpx.AsyncClient:
        return await make_client(**{"backend": "local", **overrides})

    return factory


async def test_a_crashed_worker_is_replaced_and_the_job_retried(
    client: httpx.AsyncClient, tmp_path: Path
) -> None:
    marker = tmp_path / "crashed-once"
    job = await submit(client, "crash", {"marker": str(marker)})
    done = await wait_for(client, job["jobID"])
    assert done["status"] == "successful", done
    assert done["attempts"] == 2
    assert marker.exists()
    text = (await client.get("/metrics")).text
    assert "evomesh_job_retries_total 1.0" in text
    assert 'evomesh_job_outcomes_total{outcome="crashed",process="crash"} 1.0' in text
    ready = (await client.get("/ready")).json()
    assert ready["workers"]["alive"] == 1


async def test_a_job_that_always_crashes_fails_with_the_reason(make_client: ClientFactory) -> None:
    client = await make_client(max_attempts=2)
    job = await submit(client, "crash", {})
    done = await wait_for(client, job["jobID"])
    assert done["status"] == "failed"
    assert done["attempts"] == 2
    assert "killed by SIGKILL" in done["message"]
    assert "attempt 2 of 2" in done["message"]
    follow = await submit(
        client, "mesh", {"boundary": SQUARE, "size": 0.5, "smoothing": {"method": "none"}}
    )
    assert (await wait_for(client, follow["jobID"]))["status"] == "successful"


async def test_a_job_over_its_time_limit_fails(make_client: ClientFactory) -> None:
    client = await make_client(job_timeout=0.5, cancel_grace=0.5)
    job = await submit(client, "hang", {"seconds": 60})
    done = await wait_for(client, job["jobID"], timeout=20)
    assert done["status"] == "failed"
    assert "time limit of 0.5 s" in done["message"]
    assert done["attempts"] == 1  # a time-out is not retried


async def test_a_stopped_service_resumes_its_jobs(
    make_client: ClientFactory, tmp_path: Path
) -> None:
    data = tmp_path / "shared"
    first = await make_client(data_dir=data)
    running = await submit(first, "sleep", {"seconds": 60})
    queued = [await submit(first, "sleep", {"seconds": 0.1}) for _ in range(3)]
    await wait_for(first, running["jobID"], {"running"})
    # Stop the first service as its lifespan does (the fixture's exit then finds it stopped).
    app = first.app  # type: ignore[attr-defined]
    await app.state.manager.close()
    app.state.manager = None
    store = SqliteJobStore(data / "jobs.sqlite3")
    try:
        statuses = {
            r.id: r for r in store.records([running["jobID"], *(q["jobID"] for q in queued)])
        }
    finally:
        store.close()
    assert all(r.status is JobStatus.accepted for r in statuses.values())
    assert statuses[running["jobID"]].attempts == 0  # a stop is not the job's fault

    second = await make_client(data_dir=data, workers=2)
    for job in queued:
        assert (await wait_for(second, job["jobID"]))["status"] == "successful"
    assert (await wait_for(second, running["jobID"], {"running"}))["status"] == "running"
    await second.delete(f"/jobs/{running['jobID']}")


async def test_jobs_left_running_by_a_crash_are_queued_again(
    make_client: ClientFactory, tmp_path: Path
) -> None:
    data = tmp_path / "crashed"
    data.mkdir()
    store = SqliteJobStore(data / "jobs.sqlite3")
    store.create(NewJob("left-running", "sleep", {"seconds": 0.1}))
    store.mark_running("left-running", 1)
    store.create(NewJob("worn-out", "sleep", {"seconds": 0.1}))
    store.mark_running("worn-out", 3)
    store.create(NewJob("left-queued", "sleep", {"seconds": 0.1}))
    store.close()
    client = await make_client(data_dir=data, max_attempts=3)
    done = await wait_for(client, "left-running")
    assert (done["status"], done["attempts"]) == ("successful", 2)
    assert (await wait_for(client, "left-queued"))["status"] == "successful"
    worn = await wait_for(client, "worn-out")
    assert worn["status"] == "failed"
    assert "attempt 3 of 3" in worn["message"]


async def test_old_jobs_are_purged(make_client: ClientFactory) -> None:
    client = await make_client(result_retention=0.2, purge_interval=0.1)
    job = await submit(
        client, "mesh", {"boundary": SQUARE, "size": 0.5, "smoothing": {"method": "none"}}
    )
    await wait_for(client, job["jobID"])
    deadline = time.monotonic() + 10
    while (r := await client.get(f"/jobs/{job['jobID']}")).status_code == 200:
        assert time.monotonic() < deadline, "the job was never purged"
        await anyio.sleep(0.05)
    assert_problem(r, 404, "no-such-job")


async def test_logs_carry_the_job_id(
    client: httpx.AsyncClient, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="evomesh")
    job = await submit(
        client, "mesh", {"boundary": SQUARE, "size": 0.5, "smoothing": {"method": "none"}}
    )
    await wait_for(client, job["jobID"])
    mine = [r for r in caplog.records if getattr(r, "job_id", None) == job["jobID"]]
    messages = [r.getMessage() for r in mine]
    assert "job accepted" in messages
    assert "job started" in messages
    deadline = time.monotonic() + 10
    while "job successful" not in [r.getMessage() for r in caplog.records]:
        assert time.monotonic() < deadline
        await anyio.sleep(0.02)
    lines = [JsonFormatter().format(r) for r in mine]
    assert all(json.loads(line)["job_id"] == job["jobID"] for line in lines)
