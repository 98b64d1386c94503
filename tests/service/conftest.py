"""Fixtures of the service tests: apps with their lifespan running, clients, polling helpers.

A test's service runs its jobs on the inline backend (a thread of the test's process) and keeps
them in memory unless the test asks otherwise: ``backend="local"`` (or ``"dask"``) for worker
processes, ``data_dir=...`` for a SQLite store a later app of the test opens again. Worker
faults (a killed worker, a job that ignores its stop) need worker processes; nothing else does.
"""

from __future__ import annotations

import time
from collections.abc import AsyncIterator, Awaitable, Callable, Iterator
from contextlib import AsyncExitStack
from pathlib import Path
from typing import Any

import anyio
import httpx
import pytest
from fastapi import FastAPI

from service.app import create_app
from service.jobs.memory import MemoryJobStore
from service.jobs.store import JobStore
from service.processes import PROCESSES, Process
from service.settings import Settings

from .clusters import Clusters
from .tasks import process_for

FINAL = {"successful", "failed", "dismissed"}
#: Test processes served next to the real ones.
TEST_PROCESSES: dict[str, Process] = {
    **PROCESSES,
    "sleep": process_for("sleep", "sleepy"),
    "hang": process_for("hang", "hang"),
    "crash": process_for("crash", "crash"),
    "fail": process_for("fail", "fail"),
}

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}


@pytest.fixture(scope="module")
def clusters() -> Iterator[Clusters]:
    """Dask LocalClusters (worker processes, 127.0.0.1) shared by a module's tests."""
    with Clusters() as started:
        yield started


@pytest.fixture
def anyio_backend() -> str:
    return "asyncio"


def make_settings(data_dir: Path, **overrides: Any) -> Settings:
    values: dict[str, Any] = {
        "data_dir": data_dir,
        "workers": 1,
        "cancel_grace": 2.0,
        "backend": "inline",
    }
    values.update(overrides)
    return Settings(_env_file=None, **values)  # type: ignore[call-arg]


ClientFactory = Callable[..., Awaitable[httpx.AsyncClient]]


@pytest.fixture
async def make_client(tmp_path: Path) -> AsyncIterator[ClientFactory]:
    """``await make_client(**settings)``: a client of a started app (stopped at teardown); its
    store is in memory unless ``data_dir`` (SQLite there) or ``store`` is given."""
    async with AsyncExitStack() as stack:

        async def factory(
            data_dir: Path | None = None, store: JobStore | None = None, **overrides: Any
        ) -> httpx.AsyncClient:
            if store is None and data_dir is None:
                store = MemoryJobStore()
            settings = make_settings(data_dir or tmp_path / "data", **overrides)
            app = create_app(settings, processes=TEST_PROCESSES, store=store)
            await stack.enter_async_context(app.router.lifespan_context(app))
            client = httpx.AsyncClient(
                transport=httpx.ASGITransport(app=app), base_url="http://testserver"
            )
            await stack.enter_async_context(client)
            client.app = app  # type: ignore[attr-defined]
            # Workers take tasks once warm (kernels loaded), and /ready says so: wait for it,
            # so that tests see a ready service.
            with anyio.fail_after(180):
                while (await client.get("/ready")).status_code != 200:
                    await anyio.sleep(0.05)
            return client

        yield factory


@pytest.fixture
async def client(make_client: ClientFactory) -> httpx.AsyncClient:
    return await make_client()


def app_of(client: httpx.AsyncClient) -> FastAPI:
    app: FastAPI = client.app  # type: ignore[attr-defined]
    return app


async def wait_for(
    client: httpx.AsyncClient,
    job_id: str,
    statuses: set[str] = FINAL,
    timeout: float = 60.0,
    progress_over: int | None = None,
) -> dict[str, Any]:
    """Poll a job until its status is one of ``statuses`` (and its progress passes a mark)."""
    deadline = time.monotonic() + timeout
    while True:
        r = await client.get(f"/jobs/{job_id}")
        assert r.status_code == 200, r.text
        doc: dict[str, Any] = r.json()
        if doc["status"] in statuses and (progress_over is None or doc["progress"] > progress_over):
            return doc
        assert time.monotonic() < deadline, f"job still {doc['status']} after {timeout} s: {doc}"
        await anyio.sleep(0.02)


async def submit(
    client: httpx.AsyncClient, process: str, inputs: dict[str, Any], **kwargs: Any
) -> dict[str, Any]:
    r = await client.post(f"/processes/{process}/execution", json={"inputs": inputs}, **kwargs)
    assert r.status_code == 201, r.text
    doc: dict[str, Any] = r.json()
    return doc


def assert_problem(
    r: httpx.Response, status: int, kind: str | None = None, pointer: str | None = None
) -> dict[str, Any]:
    """``r`` is an RFC 9457 problem of ``status`` (type ending in ``kind``, at ``pointer``)."""
    assert r.status_code == status, r.text
    assert r.headers["content-type"].startswith("application/problem+json"), r.headers
    doc: dict[str, Any] = r.json()
    assert {"type", "title", "status", "detail"} <= set(doc), doc
    assert doc["status"] == status
    assert isinstance(doc["detail"], str)
    assert doc["detail"]
    if kind is not None:
        assert doc["type"].endswith(kind), doc
    if pointer is not None:
        assert doc.get("pointer") == pointer, doc
    return doc
