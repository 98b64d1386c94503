"""The local backend: a supervisor of worker processes on this machine.

Each worker is a plain ``multiprocessing`` process with its own pipe, so one that dies (killed,
out of memory) is noticed through its sentinel and replaced alone, which a
``ProcessPoolExecutor`` cannot do: it breaks whole when one of its workers dies.

The supervisor's state lives on the event loop. One watcher thread waits on every worker's pipe
and sentinel and hands what it reads to the loop (``call_soon_threadsafe``), in order per worker:
reading there keeps a large result off the loop, and works the same under any event loop (an
earlier ``loop.add_reader`` design stalled under uvloop, which uvicorn uses by default; the
contract suite runs on both loops). Writing goes the other way off the loop too: a task is pickled
and written to its worker's pipe in a thread, since a payload larger than the pipe holds waits
there until the worker reads it.

Cancellation crosses the process boundary through one shared integer per worker: the supervisor
writes the running task's token there and the worker's ``should_stop()`` compares it, which costs a
memory read. A task that does not stop within the grace period has its worker killed.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import itertools
import logging
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from multiprocessing.reduction import ForkingPickler
from typing import Any

from ..task import WORKER_MODULES, Outcome, OutcomeKind, Task, run_task, settle, throttled
from .base import BackendStats, Events
from .queued import QueuedBackend

__all__ = ["LocalBackend"]

log = logging.getLogger("evomesh.worker")


def _context() -> Any:
    """forkserver where available: workers start in milliseconds from a clean, preloaded parent
    (forking the service itself would copy its threads and sockets)."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(list(WORKER_MODULES))
        return ctx
    return multiprocessing.get_context("spawn")


def _worker_main(conn: Connection, stop: Any, warmup: bool, nice: int = 0) -> None:
    """A worker: run tasks from ``conn`` until told to stop or the pipe closes."""
    # Ctrl-C in a terminal reaches the whole process group; the supervisor decides when we stop.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if nice > 0:
        # Below the service's priority: status requests keep their latency while every core
        # meshes, and the workers still get every cycle the service leaves idle.
        os.nice(nice)
    if warmup:
        import engine

        engine.warmup()  # numba kernels load from cache now, not during the first job
    # Only now does the supervisor hand us tasks: a job is never "running" (nor its time limit
    # counting) while its worker compiles kernels.
    conn.send(("ready", 0))
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg is None:
            return
        token, task = msg

        def send_progress(percent: int, message: str, token: int = token) -> None:
            conn.send(("progress", token, percent, message))

        def should_stop(token: int = token) -> bool:
            return bool(stop.value == token)

        outcome = run_task(task, throttled(send_progress), should_stop)
        try:
            conn.send(("finished", token, outcome))
        except (BrokenPipeError, OSError):
            return


@dataclass(eq=False)
class _Worker:
    process: BaseProcess
    conn: Connection
    stop: Any  #: shared int: token of the task to stop
    sentinel: int = -1
    task: Task | None = None
    token: int = 0
    started: float = 0.0
    stopping: OutcomeKind | None = None  #: cancelled or timeout, once asked to stop
    timer: asyncio.TimerHandle | None = None
    gone: bool = False  #: its death was handled (loop side)
    ready: bool = False  #: warmed up: it takes tasks
    #: The hand-over in flight (a thread writing to ``conn``): the pipe is closed only after it.
    sending: asyncio.Future[Exception | None] | None = None


class _Watcher:
    """A thread that reads the workers' pipes and notices their deaths."""

    def __init__(
        self,
        loop: asyncio.AbstractEventLoop,
        on_message: Callable[[_Worker, tuple[Any, ...]], None],
        on_death: Callable[[_Worker], None],
    ) -> None:
        self._loop = loop
        self._on_message = on_message
        self._on_death = on_death
        self._lock = threading.Lock()
        self._workers: list[_Worker] = []
        self._wake_r, self._wake_w = os.pipe()
        self._stopped = False
        self._thread = threading.Thread(target=self._run, name="evomesh-workers", daemon=True)
        self._thread.start()

    def add(self, worker: _Worker) -> None:
        with self._lock:
            self._workers.append(worker)
        self._wake()

    def _wake(self) -> None:
        with contextlib.suppress(OSError):
            os.write(self._wake_w, b"x")

    def stop(self) -> None:
        self._stopped = True
        self._wake()
        self._thread.join(10)
        for fd in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)

    def _post(self, fn: Callable[..., None], *args: Any) -> None:
        with contextlib.suppress(RuntimeError):  # the loop is closed: nobody listens any more
            self._loop.call_soon_threadsafe(fn, *args)

    def _run(self) -> None:
        while not self._stopped:
            with self._lock:
                workers = list(self._workers)
            owners: dict[Any, _Worker] = {}
            for w in workers:
                owners[w.conn] = w
                owners[w.sentinel] = w
            ready = wait([self._wake_r, *owners])
            if self._stopped:
                return
            for obj in ready:
                if obj == self._wake_r:
                    os.read(self._wake_r, 4096)
                    continue
                worker = owners[obj]
                if obj is worker.conn:
                    self._read(worker, once=True)
                else:
                    self._read(worker, once=False)  # what it sent before dying comes first
                    with self._lock:
                        self._workers.remove(worker)
                    # The loop closes the pipe (_close_pipe): a hand-over may be writing to it.
                    self._post(self._on_death, worker)

    def _read(self, worker: _Worker, *, once: bool) -> None:
        try:
            while worker.conn.poll():
                self._post(self._on_message, worker, worker.conn.recv())
                if once:
                    return
        except (EOFError, OSError):
            return  # closed: the sentinel reports the death


class LocalBackend(QueuedBackend):
    """A :class:`~service.jobs.backends.base.ComputeBackend` of local worker processes.

    ``warmup`` makes each new worker compile/load the engine's kernels before its first task;
    ``nice`` lowers the workers' scheduling priority by that much (0: the service's priority).
    """

    name = "local"

    def __init__(
        self,
        workers: int = 1,
        *,
        cancel_grace: float = 10.0,
        warmup: bool = True,
        nice: int = 0,
    ):
        if workers < 1:
            raise ValueError("workers must be at least 1")
        if not 0 <= nice <= 19:
            raise ValueError("nice must be between 0 and 19")
        super().__init__()
        self.workers = workers
        self.cancel_grace = cancel_grace
        self.warmup = warmup
        self.nice = nice
        self._ctx = _context()
        self._pool: list[_Worker] = []
        self._tokens = itertools.count(1)
        self._watcher: _Watcher | None = None
        self._spawning = 0
        self._spawns: set[asyncio.Task[None]] = set()

    # -- lifecycle -----------------------------------------------------------------------------
    async def start(self, events: Events) -> None:
        self._watcher = _Watcher(self._begin(events), self._handle, self._died)
        await asyncio.gather(*(self._spawn() for _ in range(self.workers)))

    async def _spawn(self) -> None:
        self._spawning += 1
        try:
            parent, child = self._ctx.Pipe()
            stop = self._ctx.RawValue("q", 0)
            process = self._ctx.Process(
                target=_worker_main, args=(child, stop, self.warmup, self.nice), daemon=True
            )
            # Starting can wait on the forkserver (seconds the first time): not on the loop.
            await asyncio.to_thread(process.start)
            child.close()
        finally:
            self._spawning -= 1
        worker = _Worker(process, parent, stop, sentinel=process.sentinel)
        if self._closing or self._watcher is None:
            with contextlib.suppress(OSError, ValueError):
                process.kill()
            await asyncio.to_thread(process.join, 5.0)
            parent.close()
            return
        self._pool.append(worker)
        self._watcher.add(worker)
        log.info("worker started", extra={"pid": process.pid})
        self._dispatch()

    async def close(self) -> None:
        if self._closing and self._watcher is None:
            return
        self._closing = True
        await asyncio.gather(*self._spawns, return_exceptions=True)
        pool, self._pool = self._pool, []
        self._queue.clear()
        for worker in pool:
            if worker.timer is not None:
                worker.timer.cancel()
            with contextlib.suppress(OSError, ValueError):
                if worker.task is None:
                    worker.conn.send(None)  # idle: exit cleanly
                else:
                    worker.process.kill()
        await asyncio.gather(*(asyncio.to_thread(w.process.join, 5.0) for w in pool))
        for worker in pool:
            if worker.process.is_alive():
                worker.process.kill()
                await asyncio.to_thread(worker.process.join, 5.0)
        if self._watcher is not None:
            await asyncio.to_thread(self._watcher.stop)
            self._watcher = None
        # The workers are dead: a hand-over still writing ends with a broken pipe.
        sends = [w.sending for w in pool if w.sending is not None]
        await asyncio.gather(*sends, return_exceptions=True)
        for worker in pool:
            _close_pipe(worker)
            worker.process.close()

    # -- tasks ---------------------------------------------------------------------------------
    def _stop_running(self, job_id: str) -> None:
        for worker in self._pool:
            if worker.task is not None and worker.task.job_id == job_id:
                self._stop(worker, OutcomeKind.cancelled)
                return

    def alive(self) -> bool:
        return (
            self._loop is not None
            and not self._closing
            and (any(w.process.is_alive() for w in self._pool) or self._spawning > 0)
        )

    def warm(self) -> bool:
        """True once every configured worker has warmed up and takes tasks."""
        return self.alive() and sum(1 for w in self._pool if w.ready) >= self.workers

    def stats(self) -> BackendStats:
        return BackendStats(
            workers=self.workers,
            alive=sum(1 for w in self._pool if w.process.is_alive()),
            busy=sum(1 for w in self._pool if w.task is not None),
            queued=len(self._queue),
            ready=sum(1 for w in self._pool if w.ready and not w.gone),
        )

    def worker_pids(self) -> list[int]:
        """Process ids of the workers (for operators and fault tests)."""
        return [w.process.pid for w in self._pool if w.process.pid is not None]

    def _dispatch(self) -> None:
        if self._closing:
            return
        for worker in self._pool:
            if not self._queue:
                return
            if worker.task is None and not worker.gone and worker.ready:
                self._hand_over(worker)

    def _hand_over(self, worker: _Worker) -> None:
        """Give the next task to an idle worker. It is pickled and written to the worker's pipe
        in a thread (:func:`_send`): a large payload fills the pipe faster than the worker reads
        it, and the write would hold the event loop until then. The task counts as started (its
        clock running) from now, before anything the worker answers can arrive; a worker that
        never reads it is stopped by that clock."""
        task = self._queue.popleft()
        token = next(self._tokens)
        worker.task, worker.token = task, token
        worker.started, worker.stopping = time.perf_counter(), None
        loop = self._require_loop()
        worker.timer = loop.call_later(task.timeout, self._stop, worker, OutcomeKind.timeout)
        assert self._events is not None
        self._events.started(task.job_id)
        sending = loop.run_in_executor(None, _send, worker.conn, token, task)
        worker.sending = sending
        sending.add_done_callback(functools.partial(self._sent, worker, task, token))

    def _sent(
        self, worker: _Worker, task: Task, token: int, sending: asyncio.Future[Exception | None]
    ) -> None:
        """The hand-over of ``task`` ended (on the loop): a task that could not be pickled ends
        as an error and frees the worker. A worker that died meanwhile has reported the task
        already (its sentinel: crashed), as a closing backend has."""
        refused = sending.result()
        if refused is None or self._closing or worker.task is not task or worker.token != token:
            return
        if worker.timer is not None:
            worker.timer.cancel()
            worker.timer = None
        worker.task = None
        self._refuse(task, refused)  # RecursionError, PicklingError...: the task's fault
        self._dispatch()

    def _stop(self, worker: _Worker, why: OutcomeKind) -> None:
        """Ask the worker's task to stop; kill the worker if it has not after the grace period."""
        if worker.task is None or worker.stopping is not None:
            return
        worker.stopping = why
        worker.stop.value = worker.token
        if worker.timer is not None:
            worker.timer.cancel()
        token = worker.token
        worker.timer = self._require_loop().call_later(
            self.cancel_grace, self._kill_if_stuck, worker, token
        )

    def _kill_if_stuck(self, worker: _Worker, token: int) -> None:
        if worker.task is not None and worker.token == token and not worker.gone:
            log.warning("killing a worker that did not stop", extra={"pid": worker.process.pid})
            with contextlib.suppress(OSError, ValueError):
                worker.process.kill()

    def _finish(self, worker: _Worker, outcome: Outcome) -> None:
        task = worker.task
        if task is None:
            return
        if worker.timer is not None:
            worker.timer.cancel()
            worker.timer = None
        worker.task = None
        self._report(task.job_id, settle(outcome, worker.stopping, task))
        self._dispatch()  # the worker is free

    def _handle(self, worker: _Worker, msg: tuple[Any, ...]) -> None:
        kind, token = msg[0], msg[1]
        if kind == "ready":
            worker.ready = True
            log.info("worker ready", extra={"pid": worker.process.pid})
            self._dispatch()
            return
        if token != worker.token or worker.task is None or self._closing:
            return  # a late message of a task already reported
        if kind == "progress":
            assert self._events is not None
            if worker.stopping is None:
                self._events.progress(worker.task.job_id, msg[2], msg[3])
        else:
            self._finish(worker, msg[2])

    def _died(self, worker: _Worker) -> None:
        _close_pipe(worker)
        if worker.gone or self._closing:
            return
        worker.gone = True
        worker.process.join(0)  # the sentinel fired: the exit status is there
        code = worker.process.exitcode
        if worker in self._pool:
            self._pool.remove(worker)
        if worker.task is not None:
            elapsed = time.perf_counter() - worker.started
            # (killed after the grace of a stop it was asked for: that stop, says _finish)
            self._finish(worker, Outcome(OutcomeKind.crashed, reason=_death(code), seconds=elapsed))
        log.warning("worker exited", extra={"pid": worker.process.pid, "exitcode": code})
        with contextlib.suppress(ValueError):
            worker.process.close()
        spawn = self._require_loop().create_task(self._spawn())
        self._spawns.add(spawn)  # a reference, or the task may be collected mid-flight
        spawn.add_done_callback(self._spawns.discard)
        self._dispatch()


def _close_pipe(worker: _Worker) -> None:
    """Close ``worker``'s pipe once no hand-over writes to it: closing it under a writing thread
    would hand that thread a closed handle, or a descriptor number reused by another file."""
    if worker.sending is not None and not worker.sending.done():
        worker.sending.add_done_callback(lambda _: _close_pipe(worker))
        return
    with contextlib.suppress(OSError):
        worker.conn.close()


def _send(conn: Connection, token: int, task: Task) -> Exception | None:
    """Pickle ``(token, task)`` and write it to a worker's pipe (in a thread): the pickling
    error of a task that cannot be handed over, else None. A pipe that breaks is a dying
    worker, which its sentinel reports (the task: crashed)."""
    try:
        message = ForkingPickler.dumps((token, task))
    except Exception as exc:  # RecursionError, PicklingError...
        return exc
    with contextlib.suppress(OSError, ValueError):  # broken or closed with the backend
        conn.send_bytes(message)
    return None


def _death(code: int | None) -> str:
    if code is not None and code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        return f"the worker process was killed by {name}"
    return f"the worker process exited unexpectedly (exit code {code})"
