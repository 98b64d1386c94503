"""The local backend hands a task to its worker off the event loop (issue 13, finding 5): a
payload larger than the pipe holds, sent to a worker that does not read yet, leaves the loop
free, and a dismissal or the worker's death during that hand-over ends the task as before."""

from __future__ import annotations

import asyncio
import contextlib
import os
import signal
import threading
from collections.abc import AsyncIterator, Iterator
from contextlib import contextmanager
from typing import Any

import anyio
import pytest

from service.jobs.backends.local import LocalBackend
from service.jobs.task import Outcome, OutcomeKind, Task, encode_inputs

pytestmark = pytest.mark.anyio

#: Far more than a pipe (or socket pair) buffers: the write waits for the worker to read it.
_PAYLOAD_CHARS = 24 * 1024 * 1024


def _events() -> Any:
    """An events sink recording starts and ends."""
    started: list[str] = []
    finished: dict[str, Outcome] = {}

    class _Sink:
        def started(self, job_id: str) -> None:
            started.append(job_id)

        def progress(self, job_id: str, percent: int, message: str) -> None: ...

        def finished(self, job_id: str, outcome: Outcome) -> None:
            finished[job_id] = outcome

    sink = _Sink()
    sink.starts = started  # type: ignore[attr-defined]
    sink.ends = finished  # type: ignore[attr-defined]
    return sink


@pytest.fixture
async def backend() -> AsyncIterator[tuple[LocalBackend, Any]]:
    sink = _events()
    local = LocalBackend(workers=1, warmup=False, cancel_grace=5.0)
    await local.start(sink)
    try:
        with anyio.fail_after(60):
            while not local.warm():
                await anyio.sleep(0.02)
        yield local, sink
    finally:
        await local.close()


def _large_sleep(seconds: float) -> bytes:
    """A ``sleepy`` task's stored inputs padded far past what a pipe buffers (random text, so
    that compression leaves it large)."""
    pad = os.urandom(_PAYLOAD_CHARS // 2).hex()
    data = encode_inputs({"seconds": seconds, "pad": pad})
    assert len(data) > 8 * 1024 * 1024
    return data


@contextmanager
def stopped_worker(pid: int) -> Iterator[threading.Event]:
    """The worker ``pid`` stopped (SIGSTOP: it reads nothing) until the block ends. Yields an
    event the test sets once its event loop has run on after the hand-over began; a watchdog
    resumes the worker if that does not happen within a minute (a hand-over that holds the loop
    waits for the worker to read), and the test sees it fired."""
    loop_ran = threading.Event()
    fired = threading.Event()

    def watchdog() -> None:
        if not loop_ran.wait(60):
            fired.set()
            os.kill(pid, signal.SIGCONT)

    os.kill(pid, signal.SIGSTOP)
    guard = threading.Thread(target=watchdog, daemon=True)
    guard.start()
    try:
        yield loop_ran
    finally:
        loop_ran.set()
        guard.join()
        assert not fired.is_set(), "the hand-over held the event loop until the worker read"
        with contextlib.suppress(ProcessLookupError):  # killed by the test
            os.kill(pid, signal.SIGCONT)


async def _ended(sink: Any, job_id: str) -> Outcome:
    with anyio.fail_after(60):
        while job_id not in sink.ends:
            await anyio.sleep(0.02)
    outcome: Outcome = sink.ends[job_id]
    return outcome


@contextlib.asynccontextmanager
async def large_hand_over(local: LocalBackend, seconds: float) -> AsyncIterator[int]:
    """A large ``sleepy`` task ("big") handed to the backend's stopped worker; yields the
    worker's pid once the event loop has run on after the hand-over began."""
    (pid,) = local.worker_pids()
    with stopped_worker(pid) as loop_ran:
        local.submit(Task("big", "tests.service.tasks:sleepy", _large_sleep(seconds)))
        await asyncio.sleep(0)  # the loop runs on while the worker reads nothing
        loop_ran.set()
        yield pid


async def _next_succeeds(local: LocalBackend, sink: Any) -> None:
    """A small task after the large one runs to success: the worker (or its successor) is free."""
    local.submit(Task("next", "tests.service.tasks:echo", encode_inputs({"n": 1})))
    assert (await _ended(sink, "next")).kind is OutcomeKind.succeeded


async def test_a_large_hand_over_leaves_the_loop_free_and_a_dismissal_stops_it(
    backend: tuple[LocalBackend, Any],
) -> None:
    local, sink = backend
    async with large_hand_over(local, 30) as pid:
        assert local.stats().busy == 1  # the worker is taken: nothing else goes to it
        assert sink.starts == ["big"]
        local.cancel("big")  # dismissed during the hand-over
    outcome = await _ended(sink, "big")
    assert outcome.kind is OutcomeKind.cancelled
    assert local.worker_pids() == [pid]  # stopped, not killed
    await _next_succeeds(local, sink)
    assert sink.starts == ["big", "next"]


async def test_a_worker_dying_during_a_large_hand_over_crashes_the_task(
    backend: tuple[LocalBackend, Any],
) -> None:
    local, sink = backend
    async with large_hand_over(local, 0) as pid:
        os.kill(pid, signal.SIGKILL)
    outcome = await _ended(sink, "big")
    assert outcome.kind is OutcomeKind.crashed
    assert "killed by SIGKILL" in outcome.reason
    await _next_succeeds(local, sink)  # a new worker took it
    assert local.worker_pids() != [pid]


async def test_a_large_hand_over_runs_to_success(backend: tuple[LocalBackend, Any]) -> None:
    local, sink = backend
    async with large_hand_over(local, 0):
        pass
    outcome = await _ended(sink, "big")
    assert outcome.kind is OutcomeKind.succeeded, outcome.reason
    assert sink.starts == ["big"]
