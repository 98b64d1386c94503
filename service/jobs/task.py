"""The task and the worker protocol, written once for every backend.

A :class:`Task` names a runner (``"package.module:function"``, importable where the task runs)
and carries its JSON payload. A runner is ``runner(payload, progress, should_stop) -> (data,
meta)``: ``progress(percent, message)`` reports, ``should_stop()`` is cheap and true once the
task is to stop, ``data`` is the result as bytes and ``meta`` a small JSON object of figures. A
runner that fails on purpose raises :class:`TaskError`; the engine's ``Cancelled`` is understood
too (any exception raised once ``should_stop()`` is true ends the run as cancelled).

:func:`run_task` runs a task in whatever worker (a process of the local pool, a Dask worker, a
thread of the inline backend) and says how it ended, as an :class:`Outcome`. The supervisors
report runs they stopped or lost with :func:`stopped` and :func:`settle`; every wording a user
reads about how a run ended is here.

>>> task = Task("j1", "package.module:function", {"size": 0.1}, timeout=2.0)
>>> stopped(OutcomeKind.timeout, task).reason
'stopped after exceeding the time limit of 2 s'
>>> error_outcome(TaskError("the region is empty")).reason
'the region is empty'
>>> settle(error_outcome(ZeroDivisionError("division by zero")), OutcomeKind.cancelled, task).reason
'stopped on request'
"""

from __future__ import annotations

import enum
import importlib
import json
import time
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import orjson

__all__ = [
    "PROGRESS_INTERVAL",
    "WORKER_MODULES",
    "FailureKind",
    "Outcome",
    "OutcomeKind",
    "ProgressCallback",
    "Runner",
    "StopCallback",
    "Task",
    "TaskError",
    "compact_json",
    "decode_inputs",
    "encode_inputs",
    "error_outcome",
    "handover_failed",
    "pack",
    "queued_cancel",
    "resolve_runner",
    "run_task",
    "settle",
    "stopped",
    "throttled",
    "unpack",
]

#: ``progress(percent, message)``
ProgressCallback = Callable[[int, str], None]
#: ``should_stop() -> bool``
StopCallback = Callable[[], bool]
Runner = Callable[[dict[str, Any], ProgressCallback, StopCallback], tuple[bytes, dict[str, Any]]]

#: Progress messages a worker sends at most this often (seconds); the store need not see more.
PROGRESS_INTERVAL = 0.2

#: What a worker imports before its first task (by name: the jobs package imports no process).
WORKER_MODULES = ("engine", "service.processes")


class TaskError(Exception):
    """A task failed for a reason its user should read (bad input found late, engine error)."""


@dataclass(frozen=True)
class Task:
    """One run of a job."""

    job_id: str
    runner: str  #: ``"package.module:function"``, importable where the task runs
    #: the inputs, or their stored form (:func:`encode_inputs`), decoded by :func:`run_task`
    #: in the worker: a large payload crosses the pipe as bytes, not as a pickled tree
    payload: dict[str, Any] | bytes
    attempt: int = 1
    timeout: float = 3600.0  #: seconds before the run is stopped and reported as timed out


class OutcomeKind(enum.StrEnum):
    succeeded = "succeeded"
    error = "error"  #: the runner raised (TaskError: the input's fault; other: a bug)
    crashed = "crashed"  #: the worker died (killed, out of memory, segfault)
    timeout = "timeout"
    cancelled = "cancelled"


class FailureKind(enum.StrEnum):
    """Why a job failed, kept with the job (the problem type a client is answered with)."""

    invalid_input = "invalid-input"  #: a runner's TaskError: the input's fault, found late
    internal = "internal-error"  #: a bug, or a hand-over/store failure of the service
    crashed = "job-crashed"  #: the worker died on the last attempt allowed
    timeout = "limit-exceeded"  #: over the job time limit
    backend = "backend-unavailable"  #: the compute backend could not be reached


@dataclass(frozen=True)
class Outcome:
    """How a task ended."""

    kind: OutcomeKind
    data: bytes | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    reason: str = ""  #: why, for everything but success
    seconds: float = 0.0  #: run time
    failure: FailureKind | None = None  #: for an error: whose fault (default: internal)


def resolve_runner(name: str) -> Runner:
    """The function a task's ``runner`` names."""
    module, _, attr = name.partition(":")
    fn: Runner = getattr(importlib.import_module(module), attr)
    return fn


def throttled(send: ProgressCallback, interval: float = PROGRESS_INTERVAL) -> ProgressCallback:
    """``send`` at most every ``interval`` seconds.

    Counting from now: a short task sends no progress at all (its supervisor has already marked
    it running), which spares a message and a store write per job.
    """
    last = time.monotonic()

    def progress(percent: int, message: str) -> None:
        nonlocal last
        now = time.monotonic()
        if now - last >= interval:
            last = now
            send(int(percent), str(message))

    return progress


def run_task(
    task: Task,
    progress: ProgressCallback,
    should_stop: StopCallback,
    *,
    stop_asked: StopCallback | None = None,
) -> Outcome:
    """Run ``task`` here and classify its end; never raises for the task's own failures.

    ``stop_asked`` answers, after the runner raised, whether a stop was asked (default
    ``should_stop``; a worker whose ``should_stop`` only looks now and then passes a check
    that looks at once). The supervisor words a stop it asked for (:func:`settle`).
    """
    t0 = time.perf_counter()
    payload = task.payload
    if isinstance(payload, bytes):
        try:
            payload = decode_inputs(payload)
        except ValueError as exc:
            reason = f"its stored input cannot be read: {exc}"
            return Outcome(OutcomeKind.error, reason=reason, failure=FailureKind.internal)
    try:
        data, meta = resolve_runner(task.runner)(payload, progress, should_stop)
    except Exception as exc:
        seconds = time.perf_counter() - t0
        if (stop_asked or should_stop)():
            return stopped(OutcomeKind.cancelled, task, seconds)
        return error_outcome(exc, seconds)
    return Outcome(OutcomeKind.succeeded, data, meta, seconds=time.perf_counter() - t0)


def error_outcome(exc: BaseException, seconds: float = 0.0) -> Outcome:
    """A run that raised ``exc``: a :class:`TaskError`'s message is for the user as it is;
    anything else is a bug, named with its type."""
    if isinstance(exc, TaskError):
        return Outcome(
            OutcomeKind.error, reason=str(exc), seconds=seconds, failure=FailureKind.invalid_input
        )
    reason = f"internal error: {type(exc).__name__}: {exc}"
    return Outcome(OutcomeKind.error, reason=reason, seconds=seconds, failure=FailureKind.internal)


def stopped(kind: OutcomeKind, task: Task, seconds: float = 0.0) -> Outcome:
    """A run its supervisor stopped: dismissed (``cancelled``) or over its time limit
    (``timeout``)."""
    if kind is OutcomeKind.timeout:
        reason = f"stopped after exceeding the time limit of {task.timeout:g} s"
    else:
        reason = "stopped on request"
    return Outcome(kind, reason=reason, seconds=seconds)


def settle(outcome: Outcome, stopping: OutcomeKind | None, task: Task) -> Outcome:
    """What a supervisor reports for a run: one it asked to stop (``stopping``) ends as that
    stop, however its worker ended it (returned, raised, or was killed after the grace)."""
    if stopping is None:
        return outcome
    return stopped(stopping, task, outcome.seconds)


def queued_cancel() -> Outcome:
    """A task dismissed while it waited for a worker."""
    return Outcome(OutcomeKind.cancelled, reason="dismissed before it started")


def handover_failed(exc: BaseException) -> Outcome:
    """A task that could not be handed to a worker (its payload cannot be pickled: too deep, a
    foreign object): the task's fault, so it never holds the worker."""
    reason = f"the task could not be handed to a worker: {type(exc).__name__}: {exc}"
    return Outcome(OutcomeKind.error, reason=reason, failure=FailureKind.internal)


# -- the stored form of a job's inputs ---------------------------------------------------------
def encode_inputs(inputs: dict[str, Any] | bytes) -> bytes:
    """A job's inputs as every store keeps them and a worker receives them: compact JSON
    (``json`` for what orjson refuses: integers past 64 bits), zlib level 1; bytes are that
    form already, made where the request was prepared (a body pool process, a thread) so that
    the event loop never encodes a large request.

    >>> decode_inputs(encode_inputs({"size": 0.1, "n": 2**70}))
    {'size': 0.1, 'n': 1180591620717411303424}
    """
    if isinstance(inputs, bytes):
        return inputs
    return zlib.compress(compact_json(inputs), 1)


def compact_json(value: Any) -> bytes:
    """``value`` as compact JSON: orjson, or ``json`` for what orjson refuses (integers past
    64 bits), so that nothing a request validated fails to be stored.

    >>> compact_json({"n": 2**70})
    b'{"n":1180591620717411303424}'
    """
    try:
        return orjson.dumps(value)
    except TypeError:
        return json.dumps(value, separators=(",", ":")).encode()


def decode_inputs(data: bytes) -> dict[str, Any]:
    """The inverse of :func:`encode_inputs`; :class:`ValueError` when ``data`` is not that."""
    try:
        # json, not orjson: orjson reads an integer past 64 bits as a float
        value = json.loads(zlib.decompress(data))
    except (zlib.error, ValueError, RecursionError) as exc:
        raise ValueError(str(exc) or type(exc).__name__) from None
    if not isinstance(value, dict):
        raise ValueError("it is not a JSON object")
    return value


# -- the stored form of a result document ------------------------------------------------------
def pack(doc: dict[str, Any]) -> bytes:
    """A document as stored: compact JSON (orjson: a twentieth of ``json``'s time on float
    lists), zlib level 1 (a quarter of level 6's time for a result about 5% larger)."""
    return zlib.compress(orjson.dumps(doc), 1)


def unpack(data: bytes) -> bytes:
    """The JSON bytes of a stored document."""
    return zlib.decompress(data)
