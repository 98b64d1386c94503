"""The Dask side of the Dask backend: a connection that owns the Dask thread.

:class:`DaskConnection` runs an asyncio loop of its own on a thread, holds the asynchronous
:class:`distributed.Client` and every run's state, and reports what happens through ``emit``
(thread-safe; :class:`service.jobs.backends.dask.DaskBackend` hands it to the service's loop).
Its public methods are called from the service's loop and post to the Dask loop; nothing else
crosses. See :mod:`service.jobs.backends.dask` for the protocol (events, stops, deaths,
reconnection).
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import os
import threading
import time
import uuid
from collections import deque
from collections.abc import Callable, Coroutine
from dataclasses import dataclass
from typing import Any

import dask
import distributed
from distributed import Client, Event, Future, KilledWorker, as_completed

from ..task import FailureKind, Outcome, OutcomeKind, Task, error_outcome, settle, stopped
from .dask_worker import TOPIC, Warmup, execute, is_warm, stop_name

__all__ = ["DaskConnection", "DaskOptions"]

log = logging.getLogger("evomesh.dask")

#: Seconds to connect to the scheduler, each try.
CONNECT_TIMEOUT = 5.0
#: Seconds a stale rerun's stop Event is kept on the scheduler before it is deleted.
STALE_STOP_SECONDS = 60.0


@dataclass(eq=False)
class _Run:
    """One submission of a task to Dask (Dask-thread state)."""

    task: Task
    key: str
    future: Future[Any] | None = None
    worker: str | None = None  #: where it started
    started: bool = False
    stopping: OutcomeKind | None = None  #: cancelled or timeout, once asked to stop
    stop_set: bool = False  #: its stop Event was set
    timer: asyncio.TimerHandle | None = None
    finished: bool = False


@dataclass(frozen=True)
class DaskOptions:
    """How the Dask backend uses its cluster (see :class:`.dask.DaskBackend`)."""

    scheduler: str | None = None  #: address (tcp:// or tls://); None: a LocalCluster of ours
    workers: int = 1  #: processes of a LocalCluster of ours
    cancel_grace: float = 10.0  #: seconds a stopping run gets before its worker is ended
    stop_poll: float = 0.25  #: seconds between a worker's checks for a stop request
    reconnect_timeout: float = 120.0  #: seconds waiting runs wait for a lost scheduler
    direct: bool = True  #: gather results from the workers, not through the scheduler
    warmup: bool = True  #: load the engine on every worker as it joins
    security: Any = None  #: a distributed Security for a tls:// scheduler


class DaskConnection:
    """The cluster as one client sees it, on a thread of its own (see the module docstring).

    ``emit(kind, job_id, ...)`` receives ``started``, ``progress`` and ``finished`` reports from
    the Dask thread, in order.
    """

    def __init__(self, options: DaskOptions, emit: Callable[..., None]) -> None:
        self.options = options
        self._emit = emit
        self._dloop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._prefix = f"evomesh-{uuid.uuid4().hex[:8]}"
        self._seq = itertools.count(1)
        self._cluster: Any = None
        self._client: Client | None = None
        self._address = options.scheduler or ""
        self.connected = False
        self._lost_since: float | None = time.monotonic()
        self._runs: dict[str, _Run] = {}  #: key -> run
        self._current: dict[str, _Run] = {}  #: job id -> its run
        self._waiting: list[_Run] = []  #: runs to submit once connected
        self._to_submit: list[_Run] = []
        self._to_cancel: list[Future[Any]] = []
        self._flush_scheduled = False
        self.members: set[str] = set()  #: worker addresses
        self.warm: set[str] = set()  #: addresses of workers that reported their kernels loaded
        self._stale: deque[tuple[float, str]] = deque()  #: (when, key) of stop Events to delete
        self._ac: Any = None  #: as_completed of the current client
        self._more: asyncio.Event | None = None
        self._background: set[asyncio.Task[Any]] = set()
        self._supervisor: asyncio.Task[None] | None = None

    # -- lifecycle (service loop) ------------------------------------------------------------
    async def start(self) -> None:
        """Start the Dask thread and connect (the first try only; later ones run behind)."""
        # A plain asyncio loop whatever the service runs on (uvicorn may pick uvloop).
        self._dloop = asyncio.SelectorEventLoop()
        self._thread = threading.Thread(target=self._run_loop, name="evomesh-dask", daemon=True)
        self._thread.start()
        await self._on_dask(self._open())

    def _run_loop(self) -> None:
        assert self._dloop is not None
        asyncio.set_event_loop(self._dloop)
        self._dloop.run_forever()

    async def _on_dask(self, coro: Coroutine[Any, Any, None], timeout: float | None = None) -> None:
        """Run ``coro`` on the Dask loop and wait for it from the service loop."""
        assert self._dloop is not None
        fut = asyncio.run_coroutine_threadsafe(coro, self._dloop)
        await asyncio.wait_for(asyncio.wrap_future(fut), timeout)

    async def close(self) -> None:
        """Disconnect (closing a cluster of our own) and stop the Dask thread."""
        if self._dloop is None:
            return
        try:
            await self._on_dask(self._shutdown(), timeout=60)
        except Exception:
            log.exception("the Dask backend did not shut down cleanly")
        dloop, thread = self._dloop, self._thread
        dloop.call_soon_threadsafe(dloop.stop)
        if thread is not None:
            await asyncio.to_thread(thread.join, 10)
        if not dloop.is_running():
            dloop.close()
        self._dloop = self._thread = None

    def submit(self, task: Task) -> None:
        """Queue ``task`` (from the service loop)."""
        assert self._dloop is not None
        self._dloop.call_soon_threadsafe(self._submit, task)

    def cancel(self, job_id: str) -> None:
        """Stop ``job_id``'s run (from the service loop)."""
        assert self._dloop is not None
        self._dloop.call_soon_threadsafe(self._cancel, job_id)

    # -- the Dask loop: connection ---------------------------------------------------------
    def _spawn(self, coro: Coroutine[Any, Any, Any], what: str) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._background.add(task)

        def done(t: asyncio.Task[Any]) -> None:
            self._background.discard(t)
            if not t.cancelled() and t.exception() is not None:
                log.warning("%s failed: %s", what, t.exception())

        task.add_done_callback(done)

    async def _open(self) -> None:
        if self.options.scheduler is None:
            # A LocalCluster closes a worker's nanny if, lost-worker-timeout after *any* removal
            # of it, it is gone again: a worker killed twice 15 s apart would be lost for good.
            dask.config.set({"distributed.deploy.lost-worker-timeout": "1h"})
            self._cluster = await distributed.LocalCluster(
                n_workers=self.options.workers,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address="127.0.0.1:0",
                asynchronous=True,
            )
            self._address = self._cluster.scheduler_address
        first = asyncio.Event()
        self._supervisor = asyncio.get_running_loop().create_task(self._supervise(first))
        # Start-up waits for the first try only: an unreachable scheduler is retried behind.
        await first.wait()

    async def _supervise(self, first: asyncio.Event) -> None:
        backoff = 0.2
        while True:
            try:
                client = await Client(
                    self._address,
                    asynchronous=True,
                    timeout=CONNECT_TIMEOUT,
                    direct_to_workers=self.options.direct,
                    set_as_default=False,
                    name="evomesh",
                    security=self.options.security,
                )
            except Exception as exc:  # refused, timed out, a version mismatch...
                if first.is_set():
                    log.debug("the Dask scheduler does not answer: %s", exc)
                else:
                    log.warning("the Dask scheduler at %s does not answer: %s", self._address, exc)
                first.set()
                self._expire_waiting()
                await asyncio.sleep(backoff)
                backoff = min(backoff * 2, 5.0)
                continue
            backoff = 0.2
            try:
                await self._connected_to(client)
            except Exception as exc:
                log.warning("setting up the Dask client failed: %s", exc)
                await self._drop(client)
                continue
            finally:
                first.set()
            while client.status == "running":
                await asyncio.sleep(0.1)
                self._tidy(client)
            log.error("lost the Dask scheduler at %s", self._address)
            await self._drop(client)

    async def _connected_to(self, client: Client) -> None:
        client.subscribe_topic(TOPIC, self._on_event)
        client.subscribe_topic("all", self._on_cluster_event)
        assert client.scheduler is not None
        identity = await client.scheduler.identity(n_workers=-1)
        self.members = set(identity.get("workers", {}))
        if self.options.warmup:
            try:
                await client.register_plugin(Warmup(), name="evomesh-warmup")
            except Exception as exc:  # a worker without evomesh: its jobs fail, with the reason
                log.warning("warming up the Dask workers failed: %s", exc)
            # Workers warmed before we subscribed (an earlier service) send no event: ask them.
            replies = await client.run(is_warm, on_error="return")
            self.warm = {str(a) for a, ok in replies.items() if ok is True}
        self._client = client
        self._ac = as_completed(loop=client.loop)
        self._more = asyncio.Event()
        self._spawn(self._consume(client, self._ac, self._more), "collecting results")
        self.connected = True
        self._lost_since = None
        log.info(
            "connected to the Dask scheduler",
            extra={"scheduler": self._address, "workers": len(self.members)},
        )
        waiting, self._waiting = self._waiting, []
        for run in waiting:
            self._queue(self._rekeyed(run))

    def _tidy(self, client: Client) -> None:
        """Delete the stop Events of stale reruns after a while (they had time to see them)."""
        now = time.monotonic()
        while self._stale and now - self._stale[0][0] > STALE_STOP_SECONDS:
            key = self._stale.popleft()[1]
            self._spawn(Event(stop_name(key), client=client).clear(), "a stop cleanup")

    async def _drop(self, client: Client) -> None:
        """The connection is gone (or being given up): started runs crashed, waiting ones wait."""
        was_connected = self.connected
        self.connected = False
        self._client = None
        if was_connected:
            self._lost_since = time.monotonic()
        if self._more is not None:
            self._more.set()
        self._ac = self._more = None
        self._to_submit.clear()
        self._to_cancel.clear()
        for run in list(self._runs.values()):
            if run.finished:
                continue
            if run.started:
                why = f"lost the connection to the Dask scheduler at {self._address}"
                self._finish(run, _crashed(why))
            else:
                run.future = None
                if run not in self._waiting:
                    self._waiting.append(run)
        # In the background: a client that lost its scheduler may take seconds to give up.
        self._spawn(asyncio.wait_for(client.close(), 30), "closing a Dask client")

    def _expire_waiting(self) -> None:
        """Runs waiting for a scheduler that has not come back in time end with an error."""
        if self._lost_since is None or not self._waiting:
            return
        if time.monotonic() - self._lost_since < self.options.reconnect_timeout:
            return
        waiting, self._waiting = self._waiting, []
        for run in waiting:
            self._finish(run, self._unreachable())

    def _unreachable(self) -> Outcome:
        """A run that ended without a scheduler to run it on: the backend's fault."""
        reason = (
            f"the Dask scheduler at {self._address} has been unreachable for more than "
            f"{self.options.reconnect_timeout:g} s"
        )
        return Outcome(OutcomeKind.error, reason=reason, failure=FailureKind.backend)

    async def _shutdown(self) -> None:
        if self._supervisor is not None:
            self._supervisor.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._supervisor
        client = self._client
        self.connected = False
        self._client = None
        if client is not None:
            # Started runs stop at their next poll instead of running on for nobody.
            stops = [
                Event(stop_name(r.key), client=client).set()
                for r in self._runs.values()
                if r.started and not r.finished and not r.stop_set
            ]
            with contextlib.suppress(Exception):
                await asyncio.wait_for(asyncio.gather(*stops, return_exceptions=True), 5)
            with contextlib.suppress(Exception):
                client.unsubscribe_topic("all")  # or the scheduler reports our own leaving to us
                client.unsubscribe_topic(TOPIC)
            with contextlib.suppress(Exception):
                await asyncio.wait_for(client.close(), 10)
        for run in self._runs.values():
            if run.timer is not None:
                run.timer.cancel()
        self._runs.clear()
        self._current.clear()
        self._waiting.clear()
        for task in list(self._background):
            task.cancel()
        await asyncio.gather(*self._background, return_exceptions=True)
        if self._cluster is not None:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(self._cluster.close(), 30)
            self._cluster = None

    # -- the Dask loop: tasks ----------------------------------------------------------------
    def _new_key(self, task: Task) -> str:
        return f"{self._prefix}-{task.job_id}-{task.attempt}-{next(self._seq)}"

    def _rekeyed(self, run: _Run) -> _Run:
        """The same run under a new key (a scheduler may still know the old one)."""
        self._runs.pop(run.key, None)
        fresh = _Run(run.task, self._new_key(run.task))
        self._runs[fresh.key] = fresh
        if self._current.get(run.task.job_id) is run:
            self._current[run.task.job_id] = fresh
        return fresh

    def _submit(self, task: Task) -> None:
        run = _Run(task, self._new_key(task))
        self._runs[run.key] = run
        self._current[task.job_id] = run
        if self.connected:
            self._queue(run)
        elif self._lost_since is not None and (
            time.monotonic() - self._lost_since >= self.options.reconnect_timeout
        ):
            self._finish(run, self._unreachable())
        else:
            self._waiting.append(run)

    def _queue(self, run: _Run) -> None:
        self._to_submit.append(run)
        self._schedule_flush()

    def _schedule_flush(self) -> None:
        if not self._flush_scheduled:
            self._flush_scheduled = True
            asyncio.get_running_loop().call_soon(self._flush)

    def _flush(self) -> None:
        """Submit what was queued since the last flush as one graph; cancel likewise."""
        self._flush_scheduled = False
        client = self._client
        if client is None:
            return
        runs = [r for r in self._to_submit if not r.finished]
        self._to_submit = []
        if runs:
            futures = client.map(
                execute,
                # The Task whole: Dask does not walk into it (it would into the payload's lists).
                [r.task for r in runs],
                [r.key for r in runs],
                poll=self.options.stop_poll,
                key=[r.key for r in runs],
                pure=False,
            )
            for run, future in zip(runs, futures, strict=True):
                run.future = future
            self._ac.update(futures)
            assert self._more is not None
            self._more.set()
        if self._to_cancel:
            doomed, self._to_cancel = self._to_cancel, []
            self._spawn(client.cancel(doomed), "cancelling keys")

    def _cancel(self, job_id: str) -> None:
        run = self._current.get(job_id)
        if run is None or run.finished:
            return
        if not run.started:
            if run in self._waiting:
                self._waiting.remove(run)
            self._drop_future(run)
            self._finish(run, Outcome(OutcomeKind.cancelled, reason="dismissed before it started"))
        else:
            self._stop(run, OutcomeKind.cancelled)

    def _drop_future(self, run: _Run) -> None:
        """Tell the scheduler to forget the run's key (so Dask does not run it again)."""
        if run.future is not None and self._client is not None:
            self._to_cancel.append(run.future)
            self._schedule_flush()
        run.future = None

    def _set_stop(self, key: str) -> None:
        if self._client is not None:
            self._spawn(Event(stop_name(key), client=self._client).set(), "a stop request")

    def _stop(self, run: _Run, why: OutcomeKind) -> None:
        """Ask a started run to stop; restart its worker if it has not after the grace."""
        if run.finished or run.stopping is not None:
            return
        run.stopping = why
        run.stop_set = True
        self._set_stop(run.key)
        if run.timer is not None:
            run.timer.cancel()
        run.timer = asyncio.get_running_loop().call_later(
            self.options.cancel_grace, self._kill_if_stuck, run
        )

    def _kill_if_stuck(self, run: _Run) -> None:
        if run.finished or run.stopping is None:
            return
        worker = run.worker
        log.warning(
            "killing a Dask worker whose job did not stop",
            extra={"job_id": run.task.job_id, "worker": worker},
        )
        self._drop_future(run)
        self._finish(run, stopped(run.stopping, run.task))
        if worker is not None and self._client is not None:
            self._spawn(self._kill_worker(self._client, worker), f"killing worker {worker}")

    @staticmethod
    async def _kill_worker(client: Client, address: str) -> None:
        """End a worker process at once, as a crash would; its nanny starts a fresh one.

        (``Client.restart_workers`` asks the worker to close first, which a thread that does not
        stop can hold up, and which left the nanny closed for good in some runs.)"""
        with contextlib.suppress(Exception):  # the worker dies before it can answer
            await asyncio.wait_for(
                client.run(os._exit, 1, workers=[address], on_error="ignore"), 10
            )

    def _finish(self, run: _Run, outcome: Outcome) -> None:
        if run.finished:
            return
        run.finished = True
        if run.timer is not None:
            run.timer.cancel()
            run.timer = None
        self._runs.pop(run.key, None)
        job_id = run.task.job_id
        if self._current.get(job_id) is run:
            del self._current[job_id]
        if run.future is not None:
            run.future.release()
            run.future = None
        if run.stop_set and self._client is not None:
            # The run may have ended before it saw the Event: delete it either way.
            client = self._client
            self._spawn(Event(stop_name(run.key), client=client).clear(), "a stop cleanup")
        # A run asked to stop ends as that stop, even one whose worker then died.
        outcome = settle(outcome, run.stopping, run.task)
        if not run.started and outcome.kind is OutcomeKind.succeeded:
            self._emit("started", job_id)  # its started event was lost; the order still holds
        self._emit("finished", job_id, outcome)

    # -- the Dask loop: events and results ---------------------------------------------------
    def _on_event(self, event: tuple[float, Any]) -> None:
        msg = event[1]
        if not isinstance(msg, list | tuple) or len(msg) < 2:
            return
        kind, key = msg[0], str(msg[1])
        run = self._runs.get(key)
        if kind == "warm":  # key: the worker's address
            self.warm.add(key)
        elif kind == "started":
            if run is None or run.started or run.finished:
                # A rerun Dask started on its own (its last worker died, or we let it go):
                # ours to stop, if the key is ours.
                if key.startswith(self._prefix):
                    self._set_stop(key)
                    self._stale.append((time.monotonic(), key))
                return
            run.started = True
            run.worker = str(msg[2])
            self._emit("started", run.task.job_id)
            run.timer = asyncio.get_running_loop().call_later(
                run.task.timeout, self._stop, run, OutcomeKind.timeout
            )
        elif kind == "progress" and run is not None and run.started and run.stopping is None:
            self._emit("progress", run.task.job_id, int(msg[2]), str(msg[3]))

    def _on_cluster_event(self, event: tuple[float, Any]) -> None:
        msg = event[1]
        if not isinstance(msg, dict):
            return
        action = msg.get("action")
        if action == "add-worker":
            self.members.add(str(msg["worker"]))
        elif action == "remove-worker":
            address = str(msg["worker"])
            self.members.discard(address)
            self.warm.discard(address)
            how = "left the cluster" if msg.get("expected") else "died"
            for run in list(self._runs.values()):
                if run.started and not run.finished and run.worker == address:
                    self._drop_future(run)
                    why = f"the Dask worker {address} running the job {how}"
                    self._finish(run, _crashed(why))

    async def _consume(self, client: Client, ac: Any, more: asyncio.Event) -> None:
        """Collect finished futures in batches, as they complete."""
        while True:
            try:
                first = await ac.__anext__()
            except StopAsyncIteration:
                await more.wait()
                more.clear()
                if self._client is not client:
                    return
                continue
            batch = [first, *ac.next_batch(block=False)]
            try:
                await self._collect(client, batch)
            except Exception:
                log.exception("collecting Dask results failed")

    async def _collect(self, client: Client, futures: list[Future[Any]]) -> None:
        live: list[tuple[_Run, Future[Any]]] = []
        for future in futures:
            run = self._runs.get(str(future.key))
            if run is not None and run.future is future and not run.finished:
                live.append((run, future))
        done = [(r, f) for r, f in live if f.status == "finished"]
        if done:
            try:
                values = await client.gather([f for _, f in done], direct=self.options.direct)
            except Exception:
                values = None
            if values is not None:
                for (run, _), value in zip(done, values, strict=True):
                    self._finish(run, value)
            else:  # one of them went missing: one by one
                for run, future in done:
                    try:
                        value = await client.gather(future, direct=self.options.direct)
                    except Exception as exc:
                        if not run.finished and self._client is client:
                            self._drop_future(run)
                            self._finish(run, _crashed(f"its result was lost: {exc}"))
                    else:
                        self._finish(run, value)
        for run, future in live:
            if run.finished or future.status == "finished":
                continue
            if future.status == "error":
                error = await future.exception()
                if isinstance(error, KilledWorker):
                    outcome = _crashed(f"Dask gave up on it after worker deaths: {error}")
                else:
                    outcome = error_outcome(error)
                self._finish(run, outcome)
            elif self._client is client and client.status == "running":
                # Cancelled by the scheduler (restarted by someone): run it again, counted.
                self._finish(run, _crashed("the Dask scheduler dropped the task"))


def _crashed(why: str) -> Outcome:
    return Outcome(OutcomeKind.crashed, reason=why)
