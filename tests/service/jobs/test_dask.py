"""The service on the Dask backend, through its API: a real LocalCluster of worker processes."""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import anyio
import httpx
import pytest

from ..clusters import Clusters
from ..conftest import SQUARE, ClientFactory, app_of, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

DaskClient = Callable[..., Awaitable[httpx.AsyncClient]]


@pytest.fixture
def dask_client(make_client: ClientFactory, clusters: Clusters) -> DaskClient:
    """``await dask_client(**settings)``: a started app on a 2-worker LocalCluster."""

    async def factory(**overrides: Any) -> httpx.AsyncClient:
        return await make_client(backend="dask", scheduler=clusters.address(2), **overrides)

    return factory


async def test_remote_progress_reaches_the_job_status(dask_client: DaskClient) -> None:
    client = await dask_client()
    ready = (await client.get("/ready")).json()
    assert ready["backend"] == "dask"
    assert ready["workers"]["alive"] == 2
    job = await submit(client, "sleep", {"seconds": 2})
    running = await wait_for(client, job["jobID"], {"running"}, progress_over=5)
    assert running["message"] == "sleeping"
    done = await wait_for(client, job["jobID"])
    assert (done["status"], done["progress"], done["attempts"]) == ("successful", 100, 1)


async def test_dismissal_stops_a_running_job_on_its_worker(dask_client: DaskClient) -> None:
    client = await dask_client(cancel_grace=120)  # a kill would come far too late to pass
    backend = app_of(client).state.manager.backend
    workers = backend.worker_addresses()
    job = await submit(client, "sleep", {"seconds": 60})
    await wait_for(client, job["jobID"], {"running"})
    r = await client.delete(f"/jobs/{job['jobID']}")
    assert r.json()["status"] == "dismissed"
    deadline = time.monotonic() + 15
    while backend.stats().busy:  # the remote run ends: it polled its stop Event
        assert time.monotonic() < deadline, "the remote job did not stop"
        await anyio.sleep(0.02)
    metrics = (await client.get("/metrics")).text
    assert 'evomesh_job_outcomes_total{outcome="cancelled",process="sleep"} 1.0' in metrics
    assert backend.worker_addresses() == workers  # no worker was killed to stop it
    assert (await client.get(f"/jobs/{job['jobID']}")).json()["status"] == "dismissed"


async def test_a_job_whose_worker_dies_runs_again_counted(
    dask_client: DaskClient, tmp_path: Path
) -> None:
    client = await dask_client()
    marker = tmp_path / "crashed-once"
    job = await submit(client, "crash", {"marker": str(marker), "delay": 0.5})
    done = await wait_for(client, job["jobID"], timeout=120)
    assert (done["status"], done["attempts"]) == ("successful", 2), done
    metrics = (await client.get("/metrics")).text
    assert 'evomesh_job_outcomes_total{outcome="crashed",process="crash"} 1.0' in metrics
    assert "evomesh_job_retries_total 1.0" in metrics


async def test_a_job_that_kills_every_worker_fails_after_max_attempts(
    dask_client: DaskClient,
) -> None:
    client = await dask_client(max_attempts=2)
    job = await submit(client, "crash", {"delay": 0.5})
    done = await wait_for(client, job["jobID"], timeout=120)
    assert (done["status"], done["attempts"]) == ("failed", 2), done
    assert "Dask worker" in done["message"]
    assert "attempt 2 of 2" in done["message"]


async def test_a_remote_job_over_its_time_limit_fails(dask_client: DaskClient) -> None:
    client = await dask_client(job_timeout=0.5, cancel_grace=0.5)
    job = await submit(client, "hang", {"seconds": 60})
    done = await wait_for(client, job["jobID"], timeout=60)
    assert (done["status"], done["attempts"]) == ("failed", 1)
    assert "time limit of 0.5 s" in done["message"]


async def test_backpressure_applies_on_dask_too(dask_client: DaskClient) -> None:
    client = await dask_client(max_queued=1)
    busy = []
    for _ in range(2):  # one per worker: running, so not waiting
        busy.append(await submit(client, "sleep", {"seconds": 60}))
        await wait_for(client, busy[-1]["jobID"], {"running"})
    await submit(client, "sleep", {"seconds": 0})
    r = await client.post("/processes/sleep/execution", json={"inputs": {"seconds": 0}})
    assert_problem(r, 429, "queue-full")
    assert int(r.headers["retry-after"]) >= 1
    for job in busy:
        await client.delete(f"/jobs/{job['jobID']}")


async def test_without_a_scheduler_the_service_starts_a_local_cluster(
    make_client: ClientFactory,
) -> None:
    client = await make_client(backend="dask", workers=1)
    ready = (await client.get("/ready")).json()
    assert (ready["backend"], ready["workers"]["configured"], ready["workers"]["alive"]) == (
        "dask",
        1,
        1,
    )
    address = app_of(client).state.manager.backend.worker_addresses()[0]
    assert address.startswith("tcp://127.0.0.1:")  # loopback only
    inputs = {"boundary": SQUARE, "size": 0.5, "smoothing": {"method": "none"}}
    job = await submit(client, "mesh", inputs)
    assert (await wait_for(client, job["jobID"], timeout=60))["status"] == "successful"


async def test_ready_reports_warm_dask_workers(dask_client: DaskClient) -> None:
    client = await dask_client()
    with anyio.fail_after(120):  # a worker an earlier test killed may still be warming up
        while True:
            workers = (await client.get("/ready")).json()["workers"]
            assert 1 <= workers["warm"] <= workers["alive"]  # ready: one warm worker is enough
            if (workers["alive"], workers["warm"]) == (2, 2):
                break
            await anyio.sleep(0.05)


async def test_ready_waits_for_a_warm_dask_worker(tmp_path: Path) -> None:
    from distributed import Client

    from service.app import create_app
    from service.jobs.backends.dask_worker import is_warm

    from ..clusters import local_cluster
    from ..conftest import TEST_PROCESSES, make_settings

    cluster = local_cluster(0)
    try:
        settings = make_settings(tmp_path, backend="dask", scheduler=cluster.scheduler_address)
        app = create_app(settings, processes=TEST_PROCESSES)
        transport = httpx.ASGITransport(app=app)
        async with (
            app.router.lifespan_context(app),
            httpx.AsyncClient(transport=transport, base_url="http://testserver") as client,
            Client(cluster.scheduler_address, asynchronous=True) as dask,
        ):
            assert_problem(await client.get("/ready"), 503)  # no worker at all
            cluster.scale(1)
            with anyio.fail_after(180):
                while True:
                    # Asked before /ready: a worker cold then is (all but) surely cold for it.
                    warm = await dask.run(is_warm, on_error="return")
                    r = await client.get("/ready")
                    if warm and not any(v is True for v in warm.values()):
                        assert_problem(r, 503)
                    if r.status_code == 200:
                        break
                    await anyio.sleep(0.02)
            assert r.json()["workers"]["warm"] == 1
            assert all(v is True for v in (await dask.run(is_warm)).values())
    finally:
        cluster.close()
