"""What runs on a Dask worker for the Dask backend (:mod:`service.jobs.backends.dask`).

:func:`execute` runs one task (:func:`service.jobs.task.run_task`): it reports ``started`` (with
the worker's address) and progress (rate-limited) as Dask events on :data:`TOPIC`, and hands the
runner a ``should_stop`` that asks the run's stop :class:`distributed.Event` at most every
``poll`` seconds. Every outcome but the worker's death comes back as a value. :class:`Warmup`
loads the engine on each worker as it joins and then reports ``warm`` on :data:`TOPIC`;
:func:`is_warm` answers the same for a worker asked.
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib
import threading
import time

import distributed
from distributed import Event, get_worker
from distributed.diagnostics.plugin import WorkerPlugin

from ..task import WORKER_MODULES, Outcome, Task, run_task, throttled

__all__ = ["PROGRESS_INTERVAL", "TOPIC", "Warmup", "execute", "is_warm", "stop_name"]

#: The Dask event topic workers report on (messages carry the run's key, so services sharing a
#: scheduler each pick out their own).
TOPIC = "evomesh"
#: Progress messages a worker sends at most this often (seconds).
PROGRESS_INTERVAL = 0.25


def stop_name(key: str) -> str:
    """The name of a run's stop Event."""
    return f"{key}-stop"


class _StopFlag:
    """``should_stop`` of a run on a worker: a scheduler-side Event, asked at most every ``poll``
    seconds (between asks it costs a clock read)."""

    def __init__(self, key: str, poll: float) -> None:
        self.event = Event(stop_name(key))
        self.poll = poll
        self.seen = False
        self._next = time.monotonic() + poll

    def __call__(self) -> bool:
        if self.seen:
            return True
        now = time.monotonic()
        if now < self._next:
            return False
        self._next = now + self.poll
        return self.ask()

    def ask(self) -> bool:
        try:
            self.seen = bool(self.event.is_set())
        except Exception:  # the scheduler is unreachable: keep going, the service decides
            return False
        return self.seen

    def forget(self) -> None:
        """Delete the Event on the scheduler (an Event cleared without waiters is removed)."""
        with contextlib.suppress(Exception):
            self.event.clear()


def execute(task: Task, key: str, poll: float) -> Outcome:
    """Run ``task`` (as the run ``key``) on a Dask worker; failures come back as values (only
    the worker's death is an error to Dask)."""
    worker = get_worker()
    worker.log_event(TOPIC, ["started", key, worker.address])

    def send_progress(percent: int, message: str) -> None:
        worker.log_event(TOPIC, ["progress", key, percent, message])

    stop = _StopFlag(key, poll)
    outcome = run_task(
        task,
        throttled(send_progress, PROGRESS_INTERVAL),
        stop,
        stop_asked=lambda: stop.seen or stop.ask(),
    )
    if stop.seen:
        stop.forget()
    return outcome


class Warmup(WorkerPlugin):
    """Loads the runners and the engine's compiled kernels on every worker as it joins, so the
    first job does not pay for it (in a thread: the worker keeps answering meanwhile)."""

    idempotent = True

    async def setup(self, worker: distributed.Worker) -> None:
        await asyncio.to_thread(_warm)
        # The service counts warm workers for /ready; it also asks is_warm when it connects.
        worker.log_event(TOPIC, ["warm", worker.address])


_warmed = threading.Event()


def _warm() -> None:
    for name in WORKER_MODULES:
        importlib.import_module(name)
    import engine

    engine.warmup()
    _warmed.set()


def is_warm() -> bool:
    """Whether this worker process has loaded the engine's kernels (run on a worker)."""
    return _warmed.is_set()
