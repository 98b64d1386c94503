"""The :class:`JobStore` interface: what the service needs from wherever jobs are kept.

The store is the source of truth: a job row exists before the client hears of the job, every
status change goes through it (conditionally, so late events cannot resurrect a dismissed job), and
a restarted service finds its unfinished jobs there. Every implementation passes the contract suite
in ``tests/service/jobs/test_store_contract.py``.
"""

from __future__ import annotations

import enum
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from .task import decode_inputs

__all__ = [
    "FINAL",
    "BatchRecord",
    "IdempotencyConflict",
    "JobRecord",
    "JobStatus",
    "JobStore",
    "NewJob",
    "StoreCorrupt",
    "StoreError",
    "StoreUnavailable",
    "read_inputs",
    "stored_form",
]


class JobStatus(enum.StrEnum):
    """OGC API - Processes status codes."""

    accepted = "accepted"
    running = "running"
    successful = "successful"
    failed = "failed"
    dismissed = "dismissed"


#: Statuses a job never leaves (except dismissed, which a finished job may still be given).
FINAL = frozenset({JobStatus.successful, JobStatus.failed, JobStatus.dismissed})


class StoreError(Exception):
    """The job store failed."""


class StoreUnavailable(StoreError):
    """The store cannot be written now (disk full, I/O error, locked too long): nothing was
    changed; the same call may succeed later."""


class StoreCorrupt(StoreError):
    """The store (or one stored item) cannot be read: it is not what this service wrote."""


def read_inputs(job_id: str, data: bytes) -> dict[str, Any]:
    """A job's stored inputs (:func:`~service.jobs.task.encode_inputs`' form) as every store
    reads them back: :class:`StoreCorrupt`, naming the job, when they cannot be read."""
    try:
        return decode_inputs(data)
    except ValueError as exc:
        raise StoreCorrupt(f"the stored input of job {job_id} cannot be read: {exc}") from None


def stored_form(job_id: str, data: object) -> bytes:
    """A job's stored inputs as they are (bytes), to be handed to a worker that decodes them:
    :class:`StoreCorrupt`, naming the job, when they are not even a zlib stream (its two-byte
    header, RFC 1950, checked here; a stream broken further in is found by the worker)."""
    if not isinstance(data, bytes) or len(data) < 2:
        raise StoreCorrupt(f"the stored input of job {job_id} cannot be read: it is not bytes")
    if data[0] & 0x0F != 8 or (data[0] << 8 | data[1]) % 31:
        raise StoreCorrupt(
            f"the stored input of job {job_id} cannot be read: it is not a zlib stream"
        )
    return data


class IdempotencyConflict(Exception):
    """The idempotency key was used before with a different request."""

    def __init__(self, key: str, job_id: str) -> None:
        super().__init__(f"idempotency key {key!r} was used for a different request")
        self.key = key
        self.job_id = job_id


@dataclass(frozen=True)
class NewJob:
    """A job to create."""

    id: str
    process: str
    #: resolved inputs, seed included (rerunning them gives the same mesh), or their stored
    #: form already made (:func:`~service.jobs.task.encode_inputs`), kept as given
    inputs: dict[str, Any] | bytes
    seed: int | None = None
    batch_id: str | None = None
    idempotency_key: str | None = None
    request_hash: str | None = None  #: digest of the request the key was first used with
    owner: str = ""  #: who made it (a digest of the API key; "" without keys)


@dataclass(frozen=True)
class JobRecord:
    """A job as stored (without its inputs and results, which can be large)."""

    id: str
    process: str
    status: JobStatus
    created: float  #: seconds since the epoch
    updated: float
    started: float | None = None
    finished: float | None = None
    progress: int = 0  #: 0-100
    message: str = ""  #: current stage, or why the job failed
    attempts: int = 0  #: times the job was started
    seed: int | None = None
    batch_id: str | None = None
    meta: dict[str, Any] = field(default_factory=dict)  #: result figures (e.g. triangles)
    owner: str = ""  #: who made it (a digest of the API key; "" without keys)
    #: why a failed job failed (a :class:`~service.jobs.task.FailureKind` value); "" when not
    #: failed or failed before kinds were kept (then its message tells)
    failure: str = ""


@dataclass(frozen=True)
class BatchRecord:
    """A batch: jobs created together."""

    id: str
    created: float
    process: str
    job_ids: tuple[str, ...]
    owner: str = ""


class JobStore(Protocol):
    """Where jobs live. Status changes are conditional and return whether they applied.

    A write that cannot be made raises :class:`StoreUnavailable` and changes nothing; a row that
    cannot be read is reported, never fatal to the others (an unknown status reads as failed).
    """

    def create(self, job: NewJob) -> tuple[JobRecord, bool]:
        """Insert ``job`` as accepted; returns (record, created).

        With an idempotency key already used for the same ``request_hash`` the existing job is
        returned with ``created`` false; for a different hash :class:`IdempotencyConflict`.
        """

    def create_batch(
        self, batch_id: str, process: str, jobs: Sequence[NewJob], owner: str = ""
    ) -> BatchRecord:
        """Insert a batch and its jobs at once (all or none)."""

    def get(self, job_id: str) -> JobRecord | None: ...

    def batch(self, batch_id: str) -> BatchRecord | None: ...

    def inputs(self, job_id: str) -> dict[str, Any] | None:
        """The resolved inputs the job was created with (:class:`StoreCorrupt` if unreadable)."""

    def stored_inputs(self, job_id: str) -> bytes | None:
        """The job's inputs as stored (:func:`~service.jobs.task.encode_inputs`' form), for a
        worker to decode: :func:`stored_form`'s check, nothing decoded here."""

    def search(
        self,
        *,
        status: Collection[JobStatus] = (),
        process: Collection[str] = (),
        owner: str | None = None,
        limit: int = 10,
        offset: int = 0,
    ) -> tuple[list[JobRecord], int]:
        """Jobs, newest first, and the number matching the filters (``owner``: only theirs)."""

    def records(self, job_ids: Sequence[str]) -> list[JobRecord]:
        """The records of ``job_ids`` that exist, in the order given."""

    def mark_running(self, job_id: str, attempt: int) -> bool:
        """accepted -> running, attempt number ``attempt`` (1-based)."""

    def set_progress(self, job_id: str, progress: int, message: str) -> bool:
        """Progress (0-100) and stage of a running job."""

    def finish(self, job_id: str, result: bytes, meta: dict[str, Any]) -> bool:
        """running -> successful, with the (compressed) result and its figures."""

    def fail(self, job_id: str, reason: str, kind: str = "") -> bool:
        """accepted|running -> failed with ``reason`` as message and ``kind`` (a
        :class:`~service.jobs.task.FailureKind` value) as its failure."""

    def requeue(self, job_id: str, message: str, *, keep_attempt: bool = True) -> bool:
        """running|accepted -> accepted (to run again); ``keep_attempt`` false forgets the start."""

    def dismiss(self, job_id: str) -> JobRecord | None:
        """Any status -> dismissed, dropping a result; None for an unknown job."""

    def result(self, job_id: str) -> bytes | None:
        """The stored result of a successful job."""

    def unfinished(self) -> list[JobRecord]:
        """Accepted and running jobs, oldest first."""

    def counts(self) -> dict[JobStatus, int]:
        """Jobs per status (every status present)."""

    def purge(self, finished_before: float) -> int:
        """Delete jobs that finished (or were dismissed) before the time; returns how many."""

    def set_subscriber(self, job_id: str, state: dict[str, Any] | None) -> bool:
        """Keep a job's subscriber-callback state (a JSON object; None forgets it), so that a
        restarted service resumes the deliveries not done. Returns whether the job exists."""

    def subscribed(self) -> list[tuple[str, dict[str, Any]]]:
        """``(job id, state)`` of every job with a subscriber-callback state, oldest first."""

    def ping(self) -> None:
        """Raise if the store cannot be written."""

    def close(self) -> None: ...
