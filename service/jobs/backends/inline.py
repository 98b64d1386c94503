"""The inline backend: tasks run one at a time on a thread of the service's own process.

For tests and tiny deployments: no worker process to start, warm or feed, so a service starts
in milliseconds and a test runs its jobs without spawning any. It keeps the contract of the
other backends (events on the event loop, exactly one outcome per task, cancellation and time
limits through ``should_stop``), with what a thread cannot give:

- a runner that ignores ``should_stop`` cannot be killed: past the grace its run is reported
  (cancelled or timed out) and left to end on its thread, and the next task starts on a new one;
- a runner that kills its process (or exhausts its memory) takes the service with it: there is
  no ``crashed`` outcome, nor a retry;
- jobs share the service's CPU time (one at a time: the engine's parallel kernels are not made
  to be entered from two threads at once under every threading layer).

The payload is handed over as a copy made through pickle, as a worker process would receive
it: a runner cannot change what the service holds, and a payload that cannot be pickled fails
the same way on every backend.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import pickle
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from ..task import Outcome, OutcomeKind, Task, run_task, settle, stopped, throttled
from .base import BackendStats, Events
from .queued import QueuedBackend

__all__ = ["InlineBackend"]

log = logging.getLogger("evomesh.worker")

#: Seconds :meth:`InlineBackend.close` waits for a stopped run's thread to end.
CLOSE_WAIT = 5.0


@dataclass(eq=False)
class _Run:
    """The task running now (loop-side state, but ``stop`` which its thread reads)."""

    task: Task
    thread: threading.Thread | None = None
    stop: threading.Event = field(default_factory=threading.Event)
    stopping: OutcomeKind | None = None  #: cancelled or timeout, once asked to stop
    timer: asyncio.TimerHandle | None = None
    started: float = field(default_factory=time.perf_counter)


class InlineBackend(QueuedBackend):
    """A :class:`~service.jobs.backends.base.ComputeBackend` on a thread of this process.

    ``warmup`` loads the engine's kernels before the first task (in a thread: the service
    answers meanwhile, and ``/ready`` waits for it); ``cancel_grace`` is how long a stopped run
    has to return before it is reported and left behind.
    """

    name = "inline"

    def __init__(self, *, cancel_grace: float = 10.0, warmup: bool = True) -> None:
        super().__init__()
        self.cancel_grace = cancel_grace
        self.warmup = warmup
        self._run: _Run | None = None
        self._ready = False
        self._warming: asyncio.Task[None] | None = None

    # -- lifecycle -----------------------------------------------------------------------------
    async def start(self, events: Events) -> None:
        loop = self._begin(events)
        self._ready = not self.warmup
        if self.warmup:
            self._warming = loop.create_task(self._warm())

    async def _warm(self) -> None:
        import engine

        # A job is never "running" (nor its time limit counting) while kernels load.
        await asyncio.to_thread(engine.warmup)
        self._ready = True
        self._dispatch()

    async def close(self) -> None:
        self._closing = True
        self._queue.clear()
        if self._warming is not None:
            self._warming.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._warming
            self._warming = None
        run, self._run = self._run, None
        if run is not None:
            if run.timer is not None:
                run.timer.cancel()
            run.stop.set()  # it ends at its next check, for nobody
            if run.thread is not None:
                await asyncio.to_thread(run.thread.join, CLOSE_WAIT)

    # -- tasks ---------------------------------------------------------------------------------
    def _stop_running(self, job_id: str) -> None:
        if self._run is not None and self._run.task.job_id == job_id:
            self._stop(self._run, OutcomeKind.cancelled)

    def alive(self) -> bool:
        return self._loop is not None and not self._closing

    def stats(self) -> BackendStats:
        alive = int(self.alive())
        return BackendStats(
            workers=1,
            alive=alive,
            busy=int(self._run is not None),
            queued=len(self._queue),
            ready=alive if self._ready else 0,
        )

    def _dispatch(self) -> None:
        """Start the next task that can be handed over, if nothing runs."""
        while self._run is None and self._ready and self._queue and not self._closing:
            task = self._queue.popleft()
            try:
                payload = pickle.loads(pickle.dumps(task.payload, pickle.HIGHEST_PROTOCOL))
            except Exception as exc:  # RecursionError, PicklingError...
                self._refuse(task, exc)
                continue
            run = self._run = _Run(task)
            run.thread = threading.Thread(
                target=self._work,
                args=(run, replace(task, payload=payload), self._require_loop()),
                name=f"evomesh-inline-{task.job_id}",
                daemon=True,
            )
            run.thread.start()
            run.timer = self._require_loop().call_later(
                task.timeout, self._stop, run, OutcomeKind.timeout
            )
            assert self._events is not None
            self._events.started(task.job_id)

    def _work(self, run: _Run, task: Task, loop: asyncio.AbstractEventLoop) -> None:
        """The run's thread: the task, then its outcome handed to the loop."""

        def post(fn: Callable[..., None], *args: Any) -> None:
            with contextlib.suppress(RuntimeError):  # the loop is closed: nobody listens
                loop.call_soon_threadsafe(fn, run, *args)

        progress = throttled(lambda percent, message: post(self._progress, percent, message))
        post(self._done, run_task(task, progress, run.stop.is_set))

    def _progress(self, run: _Run, percent: int, message: str) -> None:
        if run is self._run and run.stopping is None and self._events is not None:
            self._events.progress(run.task.job_id, percent, message)

    def _done(self, run: _Run, outcome: Outcome) -> None:
        if run is self._run:  # not a run already reported (left behind, or closed)
            self._finish(run, settle(outcome, run.stopping, run.task))

    def _stop(self, run: _Run, why: OutcomeKind) -> None:
        """Ask the run to stop; report it and leave it behind if it has not after the grace."""
        if run is not self._run or run.stopping is not None:
            return
        run.stopping = why
        run.stop.set()
        if run.timer is not None:
            run.timer.cancel()
        run.timer = self._require_loop().call_later(self.cancel_grace, self._leave, run)

    def _leave(self, run: _Run) -> None:
        if run is not self._run or run.stopping is None:
            return
        log.warning(
            "a task did not stop: left to end on its thread", extra={"job_id": run.task.job_id}
        )
        self._finish(run, stopped(run.stopping, run.task, time.perf_counter() - run.started))

    def _finish(self, run: _Run, outcome: Outcome) -> None:
        if run.timer is not None:
            run.timer.cancel()
            run.timer = None
        self._run = None
        self._report(run.task.job_id, outcome)
        self._dispatch()
