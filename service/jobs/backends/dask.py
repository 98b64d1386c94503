"""The Dask backend: jobs run on a Dask distributed cluster, on this machine or many.

Workers are plain ``dask worker tcp://HOST:8786`` processes on any machine with evomesh installed;
the service is one client of their scheduler. Everything Dask-facing runs on a thread of its own
with its own asyncio loop and an asynchronous :class:`distributed.Client`: the service's loop
(asyncio or uvloop) never waits on the cluster, and results are read off it. Calls from the
service post to that loop; what happens comes back in order, batched, through
``call_soon_threadsafe``.

- **Started and progress** cross as Dask events on one topic (``Worker.log_event``), which the
  scheduler forwards to this client on the same stream as task completions, so they arrive in
  order. Progress is rate-limited on the worker.
- **Stop** (dismissal, time limit) sets a per-run :class:`distributed.Event` that the worker's
  ``should_stop`` polls at most every ``stop_poll`` seconds (so a poll costs nothing between
  GA generations); a run still going after the grace has its worker process ended (its nanny
  starts another).
- **Worker death** is the scheduler's ``remove-worker`` event: runs that had started there end
  ``crashed`` and their keys are cancelled, so the manager's retry (a new key, a counted attempt)
  is the only rerun; a rerun Dask starts on its own before the cancel lands (its
  ``allowed-failures``) is told to stop as soon as its ``started`` event arrives.
- **Scheduler loss**: runs that had started end ``crashed`` (the manager counts and retries
  them); runs still waiting are kept. Both are submitted again once the scheduler answers again;
  after ``reconnect_timeout`` seconds without it, waiting runs end with an error (``failed``).
- **Results** come straight from the worker that holds them (``direct_to_workers``), gathered in
  batches: a large mesh never passes through the scheduler (see the README's figures).

``scheduler=None`` starts a :class:`distributed.LocalCluster` of ``workers`` processes on
127.0.0.1 (for trying it out on one machine).

:class:`DaskBackend` is the service-side facade (its state lives on the service's loop);
:class:`~service.jobs.backends.dask_connection.DaskConnection` owns the Dask thread and its
state; :mod:`~service.jobs.backends.dask_worker` is what runs on the workers.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from typing import Any

from ..task import Task
from .base import BackendStats, Events
from .dask_connection import DaskConnection, DaskOptions

__all__ = ["DaskBackend"]


class DaskBackend:
    """A :class:`~service.jobs.backends.base.ComputeBackend` on a Dask distributed cluster.

    ``scheduler`` is the scheduler's address (``tcp://host:8786``); ``None`` starts a local
    cluster of ``workers`` processes. ``direct`` gathers results straight from the workers
    (else through the scheduler). ``warmup`` loads the engine on every worker as it joins.
    ``security`` (a :class:`distributed.security.Security`) connects to a ``tls://`` scheduler.
    """

    name = "dask"

    def __init__(
        self,
        scheduler: str | None = None,
        *,
        workers: int = 1,
        cancel_grace: float = 10.0,
        stop_poll: float = 0.25,
        reconnect_timeout: float = 120.0,
        direct: bool = True,
        warmup: bool = True,
        security: Any = None,
    ) -> None:
        if workers < 1:
            raise ValueError("workers must be at least 1")
        self.options = DaskOptions(
            scheduler, workers, cancel_grace, stop_poll, reconnect_timeout, direct, warmup, security
        )
        # service-loop side
        self._events: Events | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._jobs: dict[str, bool] = {}  #: job id -> started, as the events told the service
        self._closing = False
        self._outbox: list[tuple[Any, ...]] = []
        self._out_lock = threading.Lock()
        self._delivery_pending = False
        self._conn: DaskConnection | None = None  #: the Dask side, while started

    # -- lifecycle (service loop) ------------------------------------------------------------
    async def start(self, events: Events) -> None:
        self._events = events
        self._loop = asyncio.get_running_loop()
        self._closing = False
        self._conn = DaskConnection(self.options, self._emit)
        await self._conn.start()

    async def close(self) -> None:
        if self._closing or self._conn is None:
            return
        self._closing = True
        await self._conn.close()
        self._conn = None
        self._jobs.clear()

    def _require_started(self) -> DaskConnection:
        if self._conn is None or self._events is None:
            raise RuntimeError("the backend is not started")
        return self._conn

    # -- tasks (service loop) ----------------------------------------------------------------
    def submit(self, task: Task) -> None:
        conn = self._require_started()
        if self._closing:
            raise RuntimeError("the backend is closing")
        self._jobs[task.job_id] = False
        conn.submit(task)

    def cancel(self, job_id: str) -> None:
        conn = self._require_started()
        if job_id in self._jobs:
            conn.cancel(job_id)

    def alive(self) -> bool:
        conn = self._conn
        return conn is not None and not self._closing and conn.connected and bool(conn.members)

    def stats(self) -> BackendStats:
        busy = sum(self._jobs.values())
        conn = self._conn
        alive = len(conn.members) if conn is not None and conn.connected else 0
        # Warm: reported by the workers (-1, not known, when they are not warmed up by us).
        ready = len(conn.warm & conn.members) if conn is not None and conn.connected else 0
        return BackendStats(
            workers=self.options.workers if self.options.scheduler is None else alive,
            alive=alive,
            busy=busy,
            queued=len(self._jobs) - busy,
            ready=ready if self.options.warmup else -1,
        )

    def ready_needed(self, stats: BackendStats) -> int:
        """Warm workers ``/ready`` waits for: all of a local cluster's, and one of a shared
        cluster's (workers that join it later must not take the service out of rotation)."""
        return stats.workers if self.options.scheduler is None else min(1, stats.workers)

    def worker_addresses(self) -> list[str]:
        """The cluster's workers (for operators and fault tests)."""
        return sorted(self._conn.members) if self._conn is not None else []

    def _deliver(self) -> None:
        """Hand what happened on the Dask side to the service's events (service loop)."""
        with self._out_lock:
            items, self._outbox = self._outbox, []
            self._delivery_pending = False
        events = self._events
        if events is None or self._closing:
            return
        for item in items:
            kind, job_id = item[0], item[1]
            if job_id not in self._jobs:
                continue
            if kind == "started":
                if not self._jobs[job_id]:
                    self._jobs[job_id] = True
                    events.started(job_id)
            elif kind == "progress":
                if self._jobs[job_id]:
                    events.progress(job_id, item[2], item[3])
            else:
                del self._jobs[job_id]
                events.finished(job_id, item[2])

    def _emit(self, *item: Any) -> None:
        """Queue a report of the Dask side for the service loop (any thread)."""
        with self._out_lock:
            self._outbox.append(item)
            if self._delivery_pending:
                return
            self._delivery_pending = True
        assert self._loop is not None
        with contextlib.suppress(RuntimeError):  # the service loop is closed: nobody listens
            self._loop.call_soon_threadsafe(self._deliver)
