"""Backpressure: beyond ``max_queued`` waiting jobs, execution and batches answer 429 with
``Retry-After``, and a batch is accepted whole or refused whole."""

from __future__ import annotations

import time

import anyio
import httpx
import pytest

from service.jobs.admission import retry_after

from ..conftest import SQUARE, ClientFactory, app_of, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

NONE = {"method": "none"}


async def _jobs(client: httpx.AsyncClient) -> int:
    total: int = (await client.get("/jobs", params={"limit": 1})).json()["numberMatched"]
    return total


async def _until_waiting(client: httpx.AsyncClient, n: int, timeout: float = 10.0) -> None:
    """Until the manager counts ``n`` waiting jobs (a dismissal reaches it through the backend)."""
    manager = app_of(client).state.manager
    deadline = time.monotonic() + timeout
    while manager.waiting != n:
        assert time.monotonic() < deadline, f"{manager.waiting} jobs waiting, not {n}"
        await anyio.sleep(0.01)


async def _fill(client: httpx.AsyncClient, waiting: int) -> tuple[str, list[str]]:
    """One long job running, ``waiting`` more queued behind it (one worker)."""
    busy = await submit(client, "sleep", {"seconds": 60})
    await wait_for(client, busy["jobID"], {"running"})
    queued = [(await submit(client, "sleep", {"seconds": 0.1}))["jobID"] for _ in range(waiting)]
    return busy["jobID"], queued


async def test_execution_beyond_max_queued_is_429_with_retry_after(
    make_client: ClientFactory,
) -> None:
    client = await make_client(max_queued=2)
    busy, queued = await _fill(client, 2)
    before = await _jobs(client)
    r = await client.post("/processes/sleep/execution", json={"inputs": {"seconds": 0.1}})
    doc = assert_problem(r, 429, "queue-full")
    assert 1 <= int(r.headers["retry-after"]) <= 60
    assert (doc["waiting"], doc["limit"]) == (2, 2)
    assert await _jobs(client) == before  # nothing was created
    metrics = (await client.get("/metrics")).text
    assert 'evomesh_jobs_refused_total{process="sleep"} 1.0' in metrics

    # A running job does not wait: dismissing a queued one makes room for exactly one.
    await client.delete(f"/jobs/{queued[0]}")
    await _until_waiting(client, 1)
    await submit(client, "sleep", {"seconds": 0.1})
    r = await client.post("/processes/sleep/execution", json={"inputs": {"seconds": 0.1}})
    assert_problem(r, 429, "queue-full")
    await client.delete(f"/jobs/{busy}")
    assert (await wait_for(client, queued[1]))["status"] == "successful"


async def test_a_batch_is_accepted_whole_or_refused_whole(make_client: ClientFactory) -> None:
    client = await make_client(max_queued=3)
    busy, _ = await _fill(client, 1)
    before = await _jobs(client)
    requests = [{"inputs": {"boundary": SQUARE, "size": 0.5, "smoothing": NONE}}] * 3
    r = await client.post("/batches", json={"process": "mesh", "requests": requests})
    assert_problem(r, 429, "queue-full")
    assert int(r.headers["retry-after"]) >= 1
    assert await _jobs(client) == before  # not one of the three

    r = await client.post("/batches", json={"process": "mesh", "requests": requests[:2]})
    assert r.status_code == 201, r.text
    assert len(r.json()["jobs"]) == 2
    assert await _jobs(client) == before + 2

    # A batch larger than max_queued could never be accepted: that is the request's fault.
    r = await client.post("/batches", json={"process": "mesh", "requests": requests * 2})
    assert_problem(r, 422, "limit-exceeded", pointer="/requests")
    await client.delete(f"/jobs/{busy}")


async def test_retry_after_follows_the_recent_throughput(make_client: ClientFactory) -> None:
    client = await make_client(max_queued=1)
    manager = app_of(client).state.manager
    for _ in range(5):  # five quick jobs leave the queue
        job = await submit(client, "sleep", {"seconds": 0})
        await wait_for(client, job["jobID"])
    busy, _ = await _fill(client, 1)
    # One job too many: Retry-After is its wait at the measured rate (which only falls while
    # nothing leaves the queue), not the 5 s given when nothing is known.
    before = retry_after(1, manager._leaving.per_second())
    r = await client.post("/processes/sleep/execution", json={"inputs": {"seconds": 0}})
    after = retry_after(1, manager._leaving.per_second())
    assert_problem(r, 429, "queue-full")
    assert before <= int(r.headers["retry-after"]) <= after
    assert manager._leaving.per_second() > 0
    await client.delete(f"/jobs/{busy}")
