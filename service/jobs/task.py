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
import time
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import orjson

__all__ = [
    "PROGRESS_INTERVAL",
    "WORKER_MODULES",
    "Outcome",
    "OutcomeKind",
    "ProgressCallback",
    "Runner",
    "StopCallback",
    "Task",
    "TaskError",
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
    payload: dict[str, Any]
    attempt: int = 1
    timeout: float = 3600.0  #: seconds before the run is stopped and reported as timed out


class OutcomeKind(enum.StrEnum):
    succeeded = "succeeded"
    error = "error"  #: the runner raised (TaskError: the input's fault; other: a bug)
    crashed = "crashed"  #: the worker died (killed, out of memory, segfault)
    timeout = "timeout"
    cancelled = "cancelled"


@dataclass(frozen=True)
class Outcome:
    """How a task ended."""

    kind: OutcomeKind
    data: bytes | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    reason: str = ""  #: why, for everything but success
    seconds: float = 0.0  #: run time


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
    try:
        data, meta = resolve_runner(task.runner)(task.payload, progress, should_stop)
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
        reason = str(exc)
    else:
        reason = f"internal error: {type(exc).__name__}: {exc}"
    return Outcome(OutcomeKind.error, reason=reason, seconds=seconds)


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
    return Outcome(OutcomeKind.error, reason=reason)


# -- the stored form of a result document ------------------------------------------------------
def pack(doc: dict[str, Any]) -> bytes:
    """A document as stored: compact JSON (orjson: a twentieth of ``json``'s time on float
    lists), zlib level 1 (a quarter of level 6's time for a result about 5% larger)."""
    return zlib.compress(orjson.dumps(doc), 1)


def unpack(data: bytes) -> bytes:
    """The JSON bytes of a stored document."""
    return zlib.decompress(data)
