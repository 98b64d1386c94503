"""The ComputeBackend contract: every implementation passes these tests.

Every submitted task ends with exactly one ``finished`` event; crashes, time-outs and
cancellations are reported as such, and the backend keeps working after each. The inline backend
runs tasks in the test's own process, so the tests that kill their worker run on the backends of
worker processes only.
"""

from __future__ import annotations

import os
import time
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import Any

import anyio
import pytest

from service.jobs.backends.base import ComputeBackend
from service.jobs.backends.inline import InlineBackend
from service.jobs.backends.local import LocalBackend
from service.jobs.task import Outcome, OutcomeKind, Task

from ..clusters import Clusters

pytestmark = pytest.mark.anyio

RUNNERS = "tests.service.tasks"

#: ``(workers, cancel grace seconds, clusters) -> backend``
Factory = Callable[[int, float, Clusters], ComputeBackend]


def _local(workers: int, grace: float, clusters: Clusters) -> ComputeBackend:
    return LocalBackend(workers=workers, cancel_grace=grace, warmup=False)


def _inline(workers: int, grace: float, clusters: Clusters) -> ComputeBackend:
    return InlineBackend(cancel_grace=grace, warmup=False)  # one thread, whatever ``workers``


def _dask(workers: int, grace: float, clusters: Clusters) -> ComputeBackend:
    from service.jobs.backends.dask import DaskBackend

    # A real LocalCluster of worker processes, shared by the module's tests (by worker count).
    return DaskBackend(clusters.address(workers), cancel_grace=grace, warmup=False)


#: Implementations by name.
IMPLEMENTATIONS: dict[str, Factory] = {"local": _local, "dask": _dask, "inline": _inline}
#: Those whose workers are processes of their own, which a task may kill.
PROCESS_IMPLEMENTATIONS = ("dask", "local")


class Recorder:
    """An Events sink that remembers everything."""

    def __init__(self) -> None:
        self.log: list[tuple[str, str, Any]] = []
        self.outcomes: dict[str, list[Outcome]] = {}

    def started(self, job_id: str) -> None:
        self.log.append(("started", job_id, None))

    def progress(self, job_id: str, percent: int, message: str) -> None:
        self.log.append(("progress", job_id, (percent, message)))

    def finished(self, job_id: str, outcome: Outcome) -> None:
        self.log.append(("finished", job_id, outcome))
        self.outcomes.setdefault(job_id, []).append(outcome)

    def events(self, job_id: str) -> list[str]:
        return [kind for kind, j, _ in self.log if j == job_id]

    async def outcome(self, job_id: str, timeout: float = 30.0) -> Outcome:
        deadline = time.monotonic() + timeout
        while job_id not in self.outcomes:
            assert time.monotonic() < deadline, f"no outcome for {job_id} in {timeout} s"
            await anyio.sleep(0.01)
        return self.outcomes[job_id][0]

    async def until_started(self, job_id: str, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while "started" not in self.events(job_id):
            assert time.monotonic() < deadline
            await anyio.sleep(0.01)


@pytest.fixture(
    params=[
        pytest.param(("asyncio", {}), id="asyncio"),
        pytest.param(("asyncio", {"use_uvloop": True}), id="uvloop"),
    ]
)
def anyio_backend(request: pytest.FixtureRequest) -> tuple[str, dict[str, Any]]:
    """Both event loops uvicorn may run: the backend must not depend on either's quirks."""
    backend: tuple[str, dict[str, Any]] = request.param
    return backend


@pytest.fixture(params=sorted(IMPLEMENTATIONS))
def impl(request: pytest.FixtureRequest) -> Factory:
    return IMPLEMENTATIONS[request.param]


@pytest.fixture(params=PROCESS_IMPLEMENTATIONS)
def process_impl(request: pytest.FixtureRequest) -> Factory:
    return IMPLEMENTATIONS[request.param]


Starter = Callable[..., Any]


async def _starter(impl: Factory, clusters: Clusters) -> AsyncIterator[Starter]:
    started: list[ComputeBackend] = []

    async def start(workers: int = 1, grace: float = 5.0) -> tuple[ComputeBackend, Recorder]:
        backend = impl(workers, grace, clusters)
        events = Recorder()
        await backend.start(events)
        started.append(backend)
        return backend, events

    yield start
    for backend in started:
        await backend.close()


@pytest.fixture
async def running(impl: Factory, clusters: Clusters) -> AsyncIterator[Starter]:
    """``await running(workers, grace)``: a started backend of each implementation."""
    async for start in _starter(impl, clusters):
        yield start


@pytest.fixture
async def running_processes(process_impl: Factory, clusters: Clusters) -> AsyncIterator[Starter]:
    """As ``running``, for the implementations whose workers a task may kill."""
    async for start in _starter(process_impl, clusters):
        yield start


def task(job_id: str, runner: str, timeout: float = 60.0, **payload: Any) -> Task:
    return Task(job_id, f"{RUNNERS}:{runner}", payload, timeout=timeout)


async def test_runs_a_task_and_reports_start_progress_result(running: Any) -> None:
    backend, events = await running()
    assert backend.alive()
    backend.submit(task("a", "sleepy", seconds=0.5))
    outcome = await events.outcome("a")
    assert outcome.kind is OutcomeKind.succeeded
    assert outcome.data == b'{"points": [], "triangles": []}'
    assert outcome.meta["triangles"] == 0
    kinds = events.events("a")
    assert kinds[0] == "started"
    assert kinds[-1] == "finished"
    assert "progress" in kinds  # at least one progress message crossed over
    percents = [p for k, j, p in events.log if k == "progress" and j == "a"]
    assert all(0 <= pct <= 100 and msg == "sleeping" for pct, msg in percents)


async def test_errors_are_reported_with_their_reason(running: Any) -> None:
    backend, events = await running()
    backend.submit(task("user", "fail", reason="the region is empty"))
    backend.submit(task("bug", "bug"))
    user, bug = await events.outcome("user"), await events.outcome("bug")
    assert (user.kind, user.reason) == (OutcomeKind.error, "the region is empty")
    assert bug.kind is OutcomeKind.error
    assert "ZeroDivisionError" in bug.reason


async def test_a_runner_cannot_change_what_was_submitted(running: Any) -> None:
    backend, events = await running()
    submitted = task("copy", "scribble", items=[1])
    backend.submit(submitted)
    outcome = await events.outcome("copy")
    assert outcome.data == repr({"items": [1, "scribbled"], "seen": True}).encode()
    assert submitted.payload == {"items": [1]}  # the worker had a copy, as across processes


async def test_a_crashed_worker_is_reported_and_replaced(running_processes: Any) -> None:
    backend, events = await running_processes(workers=1)
    backend.submit(task("boom", "crash"))
    outcome = await events.outcome("boom")
    assert outcome.kind is OutcomeKind.crashed
    assert "worker" in outcome.reason
    if backend.name == "local":
        assert "SIGKILL" in outcome.reason
    backend.submit(task("after", "echo"))
    assert (await events.outcome("after")).kind is OutcomeKind.succeeded
    assert backend.alive()
    assert backend.stats().alive == 1


async def test_cancel_a_queued_task_never_starts_it(running: Any) -> None:
    backend, events = await running(workers=1)
    backend.submit(task("busy", "sleepy", seconds=30))
    backend.submit(task("queued", "echo"))
    await events.until_started("busy")
    assert backend.stats().queued == 1
    backend.cancel("queued")
    outcome = await events.outcome("queued", timeout=5)
    assert outcome.kind is OutcomeKind.cancelled
    assert "started" not in events.events("queued")
    backend.cancel("busy")
    assert (await events.outcome("busy", timeout=10)).kind is OutcomeKind.cancelled


async def test_cancel_a_running_task_stops_it_cooperatively(running: Any) -> None:
    backend, events = await running(workers=1, grace=30.0)
    backend.submit(task("long", "sleepy", seconds=60))
    await events.until_started("long")
    t0 = time.monotonic()
    backend.cancel("long")
    outcome = await events.outcome("long", timeout=10)
    assert outcome.kind is OutcomeKind.cancelled
    assert time.monotonic() - t0 < 10  # well within the grace: should_stop was honoured
    backend.submit(task("next", "echo"))
    assert (await events.outcome("next")).kind is OutcomeKind.succeeded


async def test_a_task_that_ignores_cancel_is_killed_after_the_grace(running: Any) -> None:
    backend, events = await running(workers=1, grace=0.3)
    backend.submit(task("stuck", "hang", seconds=60))
    await events.until_started("stuck")
    backend.cancel("stuck")
    assert (await events.outcome("stuck", timeout=10)).kind is OutcomeKind.cancelled
    backend.submit(task("next", "echo"))
    assert (await events.outcome("next", timeout=30)).kind is OutcomeKind.succeeded


async def test_a_task_over_its_time_limit_times_out(running: Any) -> None:
    backend, events = await running(workers=1, grace=0.3)
    backend.submit(task("slow", "hang", timeout=0.3, seconds=60))
    outcome = await events.outcome("slow", timeout=10)
    assert outcome.kind is OutcomeKind.timeout
    assert "time limit" in outcome.reason


async def test_every_task_ends_exactly_once(running: Any) -> None:
    backend, events = await running(workers=2)
    ids = [f"t{i}" for i in range(30)]
    for job_id in ids:
        backend.submit(task(job_id, "echo", n=job_id))
    for job_id in ids:
        assert (await events.outcome(job_id)).kind is OutcomeKind.succeeded
    await anyio.sleep(0.1)
    assert all(len(events.outcomes[j]) == 1 for j in ids)
    pids = {events.outcomes[j][0].meta["pid"] for j in ids}
    assert 1 <= len(pids) <= 2
    assert backend.stats().queued == 0
    backend.cancel("unknown-job")  # a no-op


async def test_close_stops_workers_without_reporting(running: Any, tmp_path: Path) -> None:
    backend, events = await running(workers=1)
    backend.submit(task("inflight", "sleepy", seconds=60))
    await events.until_started("inflight")
    t0 = time.monotonic()
    await backend.close()
    assert time.monotonic() - t0 < 10
    assert not backend.alive()
    assert "inflight" not in events.outcomes


@pytest.mark.parametrize("nice", [0, 7])
async def test_local_workers_run_below_the_service_priority(nice: int) -> None:
    backend = LocalBackend(workers=2, warmup=False, nice=nice)
    await backend.start(Recorder())
    try:
        own = os.getpriority(os.PRIO_PROCESS, 0)
        pids = backend.worker_pids()
        assert len(pids) == 2
        want = [min(own + nice, 19)] * 2
        deadline = time.monotonic() + 30
        # A worker lowers its own priority first thing: wait until both have run that far.
        while (seen := [os.getpriority(os.PRIO_PROCESS, pid) for pid in pids]) != want:
            assert time.monotonic() < deadline, f"worker priorities {seen}, expected {want}"
            await anyio.sleep(0.01)
    finally:
        await backend.close()


def test_local_backend_refuses_a_bad_nice() -> None:
    with pytest.raises(ValueError, match="nice"):
        LocalBackend(nice=20)
