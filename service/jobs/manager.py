"""The job manager: between the HTTP routers, the store and the compute backend.

It writes every change to the store first (the source of truth), hands tasks to the backend,
turns backend events into status changes, retries runs whose worker crashed (up to
``max_attempts``), re-queues what a stopped service left unfinished, and purges old jobs.

A store that cannot be written never strands a job: a request whose row cannot be written is
refused (:class:`~service.jobs.store.StoreUnavailable`, a 503); a status change from a worker
that cannot be written is kept, in order, and retried by the reconciler, which then queues again
(or fails) every unfinished job that nothing runs. A job that cannot be handed to a worker, or
whose stored input cannot be read, is failed with the reason; it never holds a worker.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import json
import logging
import time
import uuid
from collections import Counter, deque
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import orjson

from ..metrics import Metrics
from ..processes import PROCESSES, Prepared, Process
from ..settings import Settings
from .admission import QueueFull, Throughput, retry_after
from .backends.base import ComputeBackend
from .store import BatchRecord, JobRecord, JobStore, NewJob, StoreError, StoreUnavailable
from .task import FailureKind, Outcome, OutcomeKind, Task

__all__ = ["JobManager", "request_digest"]

log = logging.getLogger("evomesh.jobs")

#: The failure kept with a job whose run ended so, when the outcome does not say (an error's
#: outcome names whose fault it was).
_FAILURES = {OutcomeKind.timeout: FailureKind.timeout, OutcomeKind.crashed: FailureKind.crashed}

#: Results up to this size are stored from the event loop (a thread hop costs more).
INLINE_RESULT_BYTES = 256 * 1024


def request_digest(process: str, body: Any) -> str:
    """A digest of a request, for idempotency keys: same JSON value, same digest.

    >>> request_digest("mesh", {"a": 1, "b": 2}) == request_digest("mesh", {"b": 2, "a": 1})
    True
    """
    try:
        text = orjson.dumps([process, body], option=orjson.OPT_SORT_KEYS)
    except TypeError:  # what orjson refuses and json takes (integers past 64 bits)
        text = json.dumps([process, body], sort_keys=True, separators=(",", ":")).encode()
    return hashlib.sha256(text).hexdigest()


class JobManager:
    """Runs jobs: store first, then backend; backend events back into the store."""

    def __init__(
        self,
        store: JobStore,
        backend: ComputeBackend,
        settings: Settings,
        metrics: Metrics,
        processes: dict[str, Process] | None = None,
    ) -> None:
        self.store = store
        self.backend = backend
        self.settings = settings
        self.metrics = metrics
        self.processes = processes if processes is not None else PROCESSES
        self._inflight: dict[str, int] = {}  #: job id -> attempt, handed to the backend
        self._running: set[str] = set()  #: job ids of _inflight that started
        self._leaving = Throughput()  #: jobs leaving the queue, for Retry-After estimates
        self._background: set[asyncio.Task[Any]] = set()
        self._purger: asyncio.Task[None] | None = None
        self._reconciler: asyncio.Task[None] | None = None
        #: Store writes that failed, oldest first, retried in this order by :meth:`reconcile`.
        self._pending: deque[tuple[str, Callable[..., Any], tuple[Any, ...]]] = deque()
        self._finishing: set[str] = set()  #: ids whose final write is on its way
        self._owners: dict[str, str] = {}  #: job id -> owner, of the jobs in _inflight
        #: Admitted jobs whose row is being written (in a thread), per owner: they count as
        #: waiting, so concurrent requests cannot pass ``max_queued`` together.
        self._creating: Counter[str] = Counter()
        self._closing = False
        #: Called with a job id after its status was written (e.g. subscriber callbacks).
        self.on_change: list[Callable[[str], None]] = []

    # -- lifecycle -----------------------------------------------------------------------------
    async def start(self) -> None:
        await self.backend.start(self)
        try:
            self.recover()
        except StoreUnavailable as exc:  # the reconciler tries again
            log.error("recovery postponed: %s", exc)
        self._purger = asyncio.create_task(self._purge_loop())
        self._reconciler = asyncio.create_task(self._reconcile_loop())

    async def close(self) -> None:
        self._closing = True
        for loop_task in (self._purger, self._reconciler):
            if loop_task is not None:
                loop_task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await loop_task
        await self.backend.close()
        await asyncio.gather(*self._background, return_exceptions=True)
        with contextlib.suppress(StoreError):
            self._replay()
        for job_id in list(self._inflight):
            # Interrupted by us, not by the job: the next start runs it again, uncounted.
            with contextlib.suppress(StoreError):
                self.store.requeue(job_id, "queued again after a service stop", keep_attempt=False)
        self._inflight.clear()
        self._running.clear()
        self._owners.clear()

    def recover(self) -> int:
        """Queue again (or fail, past ``max_attempts``) the unfinished jobs nothing runs: those a
        stopped service left, and those a failed store write left behind. A job that cannot be
        queued again is failed and logged; it never stops the others (nor the service)."""
        count = 0
        for record in self.store.unfinished():
            if record.id in self._inflight or record.id in self._finishing:
                continue
            try:
                if record.attempts >= self.settings.max_attempts:
                    self.store.fail(
                        record.id,
                        f"interrupted on attempt {record.attempts} of {self.settings.max_attempts}",
                        FailureKind.crashed,
                    )
                    continue
                self.store.requeue(record.id, "queued again after a restart")
                count += self._dispatch(
                    record.id, record.process, record.attempts + 1, owner=record.owner
                )
            except StoreUnavailable:
                raise
            except Exception as exc:
                log.exception("job could not be queued again", extra={"job_id": record.id})
                with contextlib.suppress(StoreError):
                    self.store.fail(
                        record.id, f"it could not be queued again: {exc}", FailureKind.internal
                    )
        if count:
            log.info("re-queued unfinished jobs", extra={"jobs": count})
        return count

    def _write(self, what: str, fn: Callable[..., Any], *args: Any) -> Any:
        """A store write for a backend event; one that fails is kept (behind any kept already,
        so the order holds) for the reconciler. Returns the write's result, or None if kept."""
        if not self._pending:
            try:
                result = fn(*args)
            except StoreUnavailable as exc:
                log.warning("store write postponed: %s", exc, extra={"write": what})
            else:
                self._changed(args[0])
                return result
        self._pending.append((what, fn, args))
        return None

    def _changed(self, job_id: str) -> None:
        for listener in self.on_change:
            try:
                listener(job_id)
            except Exception:  # a listener's fault must not stop the job's own work
                log.exception("status listener failed", extra={"job_id": job_id})

    def _replay(self) -> None:
        """Make the kept writes, in order; :class:`StoreUnavailable` if the store still fails."""
        while self._pending:
            what, fn, args = self._pending[0]
            try:
                fn(*args)
            except StoreUnavailable:
                raise
            except Exception:  # a write that can never be made: logged, not retried forever
                log.exception("store write dropped", extra={"write": what})
            else:
                self._changed(args[0])
            self._pending.popleft()

    def reconcile(self) -> int:
        """Retry the kept writes, then queue again what nothing runs; returns jobs re-queued."""
        self._replay()
        return self.recover()

    async def _reconcile_loop(self) -> None:
        while True:
            await asyncio.sleep(self.settings.reconcile_interval)
            try:
                self.reconcile()
            except StoreUnavailable as exc:
                log.warning("reconciliation postponed: %s", exc)
            except Exception:  # the next pass tries again
                log.exception("reconciliation failed")

    # -- requests ------------------------------------------------------------------------------
    @property
    def waiting(self) -> int:
        """Jobs handed to the backend (or being written) that have not started yet."""
        return len(self._inflight) - len(self._running) + self._creating.total()

    def waiting_for(self, owner: str) -> int:
        """Jobs of ``owner`` handed to the backend (or being written) not started yet."""
        handed = sum(
            1 for j in self._inflight if j not in self._running and self._owners.get(j) == owner
        )
        return handed + self._creating[owner]

    def admit(self, process: str, count: int, owner: str = "") -> None:
        """Raise :class:`QueueFull` unless ``count`` more jobs may wait: ``max_queued`` in all,
        and ``max_queued_per_key`` of one API key's (so one client cannot fill the queue)."""
        waiting, limit = self.waiting, self.settings.max_queued
        per_key = self.settings.max_queued_per_key
        if per_key is not None and waiting + count <= limit:
            waiting, limit = self.waiting_for(owner), per_key
        if waiting + count > limit:
            self.metrics.refused.labels(process).inc(count)
            wait = retry_after(waiting + count - limit, self._leaving.per_second())
            raise QueueFull(waiting, limit, count, wait)

    async def submit(
        self,
        process: Process,
        prepared: Prepared,
        *,
        idempotency_key: str | None = None,
        request_hash: str | None = None,
        owner: str = "",
    ) -> tuple[JobRecord, bool]:
        """Create a job (written before anyone hears of it) and queue it; :class:`QueueFull`
        when too many wait already. Idempotency keys are the ``owner``'s own.

        The row is written in a thread (a large request's inputs are megabytes, and SQLite may
        wait on its lock); ``prepared.inputs`` is best their stored form already (bytes), so
        nothing is encoded here, and the worker gets those bytes as they are."""
        self.admit(process.id, 1, owner)
        job = NewJob(
            id=str(uuid.uuid4()),
            process=process.id,
            inputs=prepared.inputs,
            seed=prepared.seed,
            idempotency_key=None if idempotency_key is None else f"{owner}:{idempotency_key}",
            request_hash=request_hash,
            owner=owner,
        )
        with self._writing(owner, 1):
            record, created = await asyncio.to_thread(self.store.create, job)
        if created:
            self.metrics.submitted.labels(process.id).inc()
            log.info("job accepted", extra={"job_id": record.id, "processID": process.id})
            if not self._closing:  # else left accepted: the next start's recovery runs it
                self._dispatch(record.id, process.id, 1, prepared.inputs, owner)
        return record, created

    async def submit_batch(
        self, process: Process, items: Sequence[Prepared], owner: str = ""
    ) -> BatchRecord:
        """Create the jobs of a batch in one transaction, then queue them: all of them, or none
        (:class:`QueueFull`). Written in a thread, as :meth:`submit` writes a job; the items'
        inputs are best their stored form already (bytes), handed to the workers as they are."""
        self.admit(process.id, len(items), owner)
        batch_id = str(uuid.uuid4())
        jobs = [
            NewJob(str(uuid.uuid4()), process.id, p.inputs, p.seed, batch_id=batch_id, owner=owner)
            for p in items
        ]
        with self._writing(owner, len(jobs)):
            batch = await asyncio.to_thread(
                self.store.create_batch, batch_id, process.id, jobs, owner
            )
        self.metrics.submitted.labels(process.id).inc(len(jobs))
        log.info("batch accepted", extra={"batch_id": batch_id, "jobs": len(jobs)})
        for job in jobs:
            if not self._closing:  # else left accepted: the next start's recovery runs it
                self._dispatch(job.id, process.id, 1, job.inputs, owner)
        return batch

    @contextlib.contextmanager
    def _writing(self, owner: str, count: int) -> Iterator[None]:
        """``count`` admitted jobs of ``owner`` whose rows are being written: they count as
        waiting meanwhile (:meth:`admit`)."""
        self._creating[owner] += count
        try:
            yield
        finally:
            self._creating[owner] -= count
            if not self._creating[owner]:
                del self._creating[owner]

    def dismiss(self, job_id: str) -> JobRecord | None:
        """Dismiss a job: a queued one never runs, a running one is stopped."""
        record = self.store.dismiss(job_id)
        if record is not None and job_id in self._inflight:
            self.backend.cancel(job_id)
        if record is not None:
            log.info("job dismissed", extra={"job_id": job_id})
        return record

    def _dispatch(
        self,
        job_id: str,
        process_id: str,
        attempt: int,
        inputs: dict[str, Any] | bytes | None = None,
        owner: str | None = None,
    ) -> bool:
        """Hand a job to the backend; a job that cannot be handed over is failed with the
        reason (and holds no worker). Returns whether it was handed over."""
        process = self.processes.get(process_id)
        if process is None:
            reason = f"process {process_id!r} is not available"
            self._write("fail", self.store.fail, job_id, reason, FailureKind.internal)
            return False
        try:
            # the stored bytes as they are: only the worker decodes them
            payload = inputs if inputs is not None else self.store.stored_inputs(job_id)
        except StoreUnavailable:
            raise
        except Exception as exc:
            log.error("stored input unreadable: %s", exc, extra={"job_id": job_id})
            reason = f"its stored input cannot be read: {exc}"
            self._write("fail", self.store.fail, job_id, reason, FailureKind.internal)
            return False
        if payload is None:  # purged meanwhile
            return False
        self._inflight[job_id] = attempt
        if owner is not None:  # a retry keeps the owner it had
            self._owners[job_id] = owner
        try:
            self.backend.submit(
                Task(job_id, process.runner, payload, attempt, self.settings.job_timeout)
            )
        except Exception as exc:
            self._inflight.pop(job_id, None)
            self._owners.pop(job_id, None)
            reason = f"the job could not be handed to a worker: {type(exc).__name__}: {exc}"
            log.error(reason, extra={"job_id": job_id})
            self._write("fail", self.store.fail, job_id, reason, FailureKind.internal)
            return False
        return True

    # -- backend events (on the event loop) ----------------------------------------------------
    def started(self, job_id: str) -> None:
        attempt = self._inflight.get(job_id, 1)
        if self._write("running", self.store.mark_running, job_id, attempt) is False:
            self.backend.cancel(job_id)  # dismissed meanwhile
            return
        if job_id in self._inflight:
            self._running.add(job_id)
        if attempt > 1:
            self.metrics.retries.inc()
        log.info("job started", extra={"job_id": job_id, "attempt": attempt})

    def progress(self, job_id: str, percent: int, message: str) -> None:
        if self._pending:
            return  # behind a kept status change: it would not apply
        with contextlib.suppress(StoreUnavailable):  # progress is not worth keeping
            self.store.set_progress(job_id, percent, message)

    def finished(self, job_id: str, outcome: Outcome) -> None:
        attempt = self._inflight.pop(job_id, None)
        if attempt is None:
            return
        owner = self._owners.pop(job_id, "")
        self._running.discard(job_id)
        self._leaving.record()
        try:
            record = self.store.get(job_id)
        except StoreError:
            record = None
        process = record.process if record else "?"
        self.metrics.outcomes.labels(process, outcome.kind.value).inc()
        extra = {"job_id": job_id, "attempt": attempt, "outcome": outcome.kind.value}
        if outcome.kind is OutcomeKind.succeeded:
            self._spawn(self._succeeded(job_id, process, outcome))
        elif outcome.kind is OutcomeKind.crashed:
            if attempt < self.settings.max_attempts and not self._closing:
                log.warning("job retried: %s", outcome.reason, extra=extra)
                requeued = self._write(
                    "requeue", self.store.requeue, job_id, f"retrying after: {outcome.reason}"
                )
                if requeued:  # (a kept requeue is run again by the reconciler)
                    self._dispatch(job_id, process, attempt + 1, owner=owner)
            else:
                reason = f"{outcome.reason} (attempt {attempt} of {self.settings.max_attempts})"
                log.error("job failed: %s", reason, extra=extra)
                self._write("fail", self.store.fail, job_id, reason, FailureKind.crashed)
        elif outcome.kind is OutcomeKind.cancelled:
            log.info("job stopped", extra=extra)
        else:
            log.warning("job failed: %s", outcome.reason, extra=extra)
            kind = outcome.failure or _FAILURES.get(outcome.kind, FailureKind.internal)
            self._write("fail", self.store.fail, job_id, outcome.reason, kind)

    async def _succeeded(self, job_id: str, process: str, outcome: Outcome) -> None:
        data = outcome.data or b""
        self._finishing.add(job_id)
        try:
            if self._pending or len(data) <= INLINE_RESULT_BYTES:
                done = self._write("finish", self.store.finish, job_id, data, outcome.meta)
            else:  # a large result takes a while to write: not on the event loop
                done = await asyncio.to_thread(self.store.finish, job_id, data, outcome.meta)
                self._changed(job_id)
        except StoreUnavailable as exc:
            log.warning("store write postponed: %s", exc, extra={"write": "finish"})
            self._pending.append(("finish", self.store.finish, (job_id, data, outcome.meta)))
            done = None
        finally:
            self._finishing.discard(job_id)
        if done:
            self.metrics.duration.labels(process).observe(outcome.seconds)
            self.metrics.triangles.inc(int(outcome.meta.get("triangles", 0)))
            log.info(
                "job successful",
                extra={
                    "job_id": job_id,
                    "seconds": round(outcome.seconds, 4),
                    "figures": outcome.meta,
                },
            )

    def _spawn(self, coro: Any) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._background.add(task)
        task.add_done_callback(self._background.discard)

    async def _purge_loop(self) -> None:
        while True:
            cutoff = time.time() - self.settings.result_retention
            try:
                n = await asyncio.to_thread(self.store.purge, cutoff)
                if n:
                    log.info("purged old jobs", extra={"jobs": n})
            except Exception:  # a failed purge must not stop the service; it tries again
                log.exception("purge failed")
            await asyncio.sleep(self.settings.purge_interval)
