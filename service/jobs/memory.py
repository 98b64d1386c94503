"""The in-memory job store: the SQLite store's semantics without a file, for tests and trials.

Everything lives in a :class:`MemoryTables` (jobs in creation order, results, batches) behind
one lock; a store opened again on the same tables finds what the last one left, as a store
opened again on the same file does. Inputs and figures are kept as JSON and decoded on each
read, so a caller gets what the SQLite store would give (lists, not tuples; its own copy).
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import orjson

from .store import (
    FINAL,
    BatchRecord,
    IdempotencyConflict,
    JobRecord,
    JobStatus,
    NewJob,
    StoreError,
    StoreUnavailable,
    read_inputs,
    stored_form,
)
from .task import compact_json, encode_inputs

__all__ = ["MemoryJobStore", "MemoryTables"]

_UNFINISHED = frozenset({JobStatus.accepted, JobStatus.running})


@dataclass(eq=False)
class _Row:
    seq: int
    record: JobRecord
    inputs: bytes  #: as the SQLite store keeps them (:func:`~.task.encode_inputs`)
    idempotency_key: str | None
    request_hash: str | None
    subscriber: bytes = b""  #: JSON callback state, b"" when none


@dataclass(eq=False)
class MemoryTables:
    """What a :class:`MemoryJobStore` keeps; outlives the store (its "file")."""

    jobs: dict[str, _Row] = field(default_factory=dict)  #: by id, in creation order
    keys: dict[str, str] = field(default_factory=dict)  #: idempotency key -> job id
    results: dict[str, bytes] = field(default_factory=dict)
    batches: dict[str, tuple[str, float, str]] = field(
        default_factory=dict
    )  #: process, created, owner
    seq: int = 0
    lock: threading.Lock = field(default_factory=threading.Lock)


class MemoryJobStore:
    """A :class:`~service.jobs.store.JobStore` in memory (lost with the process).

    >>> store = MemoryJobStore()
    >>> store.create(NewJob("j1", "mesh", {"size": 0.1}))[0].status
    <JobStatus.accepted: 'accepted'>
    >>> store.mark_running("j1", 1), store.mark_running("j1", 2)
    (True, False)
    """

    def __init__(
        self, *, clock: Callable[[], float] = time.time, tables: MemoryTables | None = None
    ) -> None:
        self._clock = clock
        self.tables = tables if tables is not None else MemoryTables()
        self._closed = False

    def _open(self) -> MemoryTables:
        if self._closed:
            raise StoreUnavailable("the job store is closed")
        return self.tables

    def close(self) -> None:
        self._closed = True

    def ping(self) -> None:
        self._open()

    # -- creation ----------------------------------------------------------------------------
    def _insert(self, t: MemoryTables, job: NewJob, now: float) -> JobRecord:
        record = JobRecord(
            id=job.id,
            process=job.process,
            status=JobStatus.accepted,
            created=now,
            updated=now,
            seed=job.seed,
            batch_id=job.batch_id,
            owner=job.owner,
        )
        t.seq += 1
        t.jobs[job.id] = _Row(
            t.seq, record, encode_inputs(job.inputs), job.idempotency_key, job.request_hash
        )
        if job.idempotency_key is not None:
            t.keys[job.idempotency_key] = job.id
        return record

    def create(self, job: NewJob) -> tuple[JobRecord, bool]:
        t = self._open()
        with t.lock:
            now = self._clock()
            if job.idempotency_key is not None and job.idempotency_key in t.keys:
                row = t.jobs[t.keys[job.idempotency_key]]
                if row.request_hash != job.request_hash:
                    raise IdempotencyConflict(job.idempotency_key, row.record.id)
                return row.record, False
            if job.id in t.jobs:
                raise StoreError(f"job {job.id} exists already")
            return self._insert(t, job, now), True

    def create_batch(
        self, batch_id: str, process: str, jobs: Sequence[NewJob], owner: str = ""
    ) -> BatchRecord:
        t = self._open()
        with t.lock:
            now = self._clock()
            taken = [j.id for j in jobs if j.id in t.jobs]
            keys = [j.idempotency_key for j in jobs if j.idempotency_key in t.keys]
            ids = [j.id for j in jobs]
            if batch_id in t.batches or taken or keys or len(set(ids)) < len(ids):
                raise StoreError(f"batch {batch_id} repeats an existing id: {taken or keys or ids}")
            t.batches[batch_id] = (process, now, owner)
            for job in jobs:
                self._insert(t, job, now)
        return BatchRecord(batch_id, now, process, tuple(ids), owner)

    # -- reads -------------------------------------------------------------------------------
    def get(self, job_id: str) -> JobRecord | None:
        t = self._open()
        row = t.jobs.get(job_id)
        return None if row is None else row.record

    def batch(self, batch_id: str) -> BatchRecord | None:
        t = self._open()
        with t.lock:
            if batch_id not in t.batches:
                return None
            process, created, owner = t.batches[batch_id]
            ids = tuple(r.record.id for r in t.jobs.values() if r.record.batch_id == batch_id)
        return BatchRecord(batch_id, created, process, ids, owner)

    def inputs(self, job_id: str) -> dict[str, Any] | None:
        row = self._open().jobs.get(job_id)
        if row is None:
            return None
        return read_inputs(job_id, row.inputs)

    def stored_inputs(self, job_id: str) -> bytes | None:
        row = self._open().jobs.get(job_id)
        return None if row is None else stored_form(job_id, row.inputs)

    def search(
        self,
        *,
        status: Collection[JobStatus] = (),
        process: Collection[str] = (),
        owner: str | None = None,
        limit: int = 10,
        offset: int = 0,
    ) -> tuple[list[JobRecord], int]:
        t = self._open()
        statuses = {JobStatus(s) for s in status}
        processes = set(process)
        with t.lock:
            found = [
                r.record
                for r in reversed(t.jobs.values())
                if (owner is None or r.record.owner == owner)
                and (not statuses or r.record.status in statuses)
                and (not processes or r.record.process in processes)
            ]
        return found[offset : offset + limit], len(found)

    def records(self, job_ids: Sequence[str]) -> list[JobRecord]:
        t = self._open()
        with t.lock:
            return [t.jobs[i].record for i in job_ids if i in t.jobs]

    def result(self, job_id: str) -> bytes | None:
        return self._open().results.get(job_id)

    def unfinished(self) -> list[JobRecord]:
        t = self._open()
        with t.lock:
            return [r.record for r in t.jobs.values() if r.record.status in _UNFINISHED]

    def counts(self) -> dict[JobStatus, int]:
        t = self._open()
        out = dict.fromkeys(JobStatus, 0)
        with t.lock:
            for row in t.jobs.values():
                out[row.record.status] += 1
        return out

    # -- status changes ----------------------------------------------------------------------
    def _change(
        self,
        job_id: str,
        allowed: Collection[JobStatus],
        change: Callable[[JobRecord, float], JobRecord],
    ) -> bool:
        """Apply ``change`` to the job if its status is one of ``allowed``."""
        t = self._open()
        with t.lock:
            now = self._clock()  # read whatever happens, as the SQLite store does
            row = t.jobs.get(job_id)
            if row is None or row.record.status not in allowed:
                return False
            row.record = change(row.record, now)
            return True

    def mark_running(self, job_id: str, attempt: int) -> bool:
        return self._change(
            job_id,
            {JobStatus.accepted},
            lambda r, now: replace(
                r,
                status=JobStatus.running,
                attempts=attempt,
                started=now,
                updated=now,
                progress=0,
                message="started",
            ),
        )

    def set_progress(self, job_id: str, progress: int, message: str) -> bool:
        percent = max(0, min(100, int(progress)))
        return self._change(
            job_id,
            {JobStatus.running},
            lambda r, now: replace(r, progress=percent, message=message, updated=now),
        )

    def finish(self, job_id: str, result: bytes, meta: dict[str, Any]) -> bool:
        figures = json.loads(compact_json(meta))  # a copy, as stored
        done = self._change(
            job_id,
            {JobStatus.running},
            lambda r, now: replace(
                r,
                status=JobStatus.successful,
                progress=100,
                message="done",
                finished=now,
                updated=now,
                meta=figures,
            ),
        )
        if done:
            with self.tables.lock:
                self.tables.results[job_id] = bytes(result)
        return done

    def fail(self, job_id: str, reason: str, kind: str = "") -> bool:
        return self._change(
            job_id,
            _UNFINISHED,
            lambda r, now: replace(
                r,
                status=JobStatus.failed,
                message=reason,
                failure=kind,
                finished=now,
                updated=now,
            ),
        )

    def requeue(self, job_id: str, message: str, *, keep_attempt: bool = True) -> bool:
        return self._change(
            job_id,
            _UNFINISHED,
            lambda r, now: replace(
                r,
                status=JobStatus.accepted,
                progress=0,
                message=message,
                started=None,
                updated=now,
                attempts=r.attempts if keep_attempt else max(r.attempts - 1, 0),
            ),
        )

    def dismiss(self, job_id: str) -> JobRecord | None:
        t = self._open()
        with t.lock:
            now = self._clock()
            row = t.jobs.get(job_id)
            if row is None:
                return None
            if row.record.status is not JobStatus.dismissed:
                row.record = replace(
                    row.record,
                    status=JobStatus.dismissed,
                    message="dismissed",
                    updated=now,
                    finished=now if row.record.finished is None else row.record.finished,
                )
            t.results.pop(job_id, None)
            return row.record

    def purge(self, finished_before: float) -> int:
        t = self._open()
        with t.lock:
            old = [
                row
                for row in t.jobs.values()
                if row.record.status in FINAL
                and row.record.finished is not None
                and row.record.finished < finished_before
            ]
            for row in old:
                del t.jobs[row.record.id]
                t.results.pop(row.record.id, None)
                if row.idempotency_key is not None:
                    t.keys.pop(row.idempotency_key, None)
            kept = {r.record.batch_id for r in t.jobs.values()}
            for batch_id in [b for b in t.batches if b not in kept]:
                del t.batches[batch_id]
        return len(old)

    # -- subscriber callbacks ----------------------------------------------------------------
    def set_subscriber(self, job_id: str, state: dict[str, Any] | None) -> bool:
        t = self._open()
        with t.lock:
            row = t.jobs.get(job_id)
            if row is None:
                return False
            row.subscriber = b"" if state is None else compact_json(state)
            return True

    def subscribed(self) -> list[tuple[str, dict[str, Any]]]:
        t = self._open()
        with t.lock:
            rows = sorted((r for r in t.jobs.values() if r.subscriber), key=lambda r: r.seq)
            return [(r.record.id, orjson.loads(r.subscriber)) for r in rows]
