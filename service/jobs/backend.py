"""The :class:`ComputeBackend` interface: something that runs tasks and reports what happened.

A backend runs :class:`Task` objects (a runner named ``"module:function"`` and its JSON payload)
somewhere else than the event loop and reports to an :class:`Events` sink, on the event loop:
``started`` once per run, ``progress`` any number of times, then exactly one ``finished`` with an
:class:`Outcome` for every task submitted, whether it succeeded, failed, crashed its worker, ran
out of time or was cancelled. Retrying is the caller's business. Every implementation passes the
contract suite in ``tests/service/test_backend_contract.py``; :mod:`service.jobs.factory` builds
one from the settings (this interface imports no implementation).

A runner is ``runner(payload, progress, should_stop) -> (data, meta)`` where ``progress(percent,
message)`` reports, ``should_stop()`` is cheap and true once the task is cancelled, ``data`` is the
result as bytes and ``meta`` a small JSON object of figures. A runner that fails on purpose raises
:class:`TaskError`; the engine's ``Cancelled`` is understood too.
"""

from __future__ import annotations

import enum
import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

__all__ = [
    "BackendStats",
    "ComputeBackend",
    "Events",
    "Outcome",
    "OutcomeKind",
    "ProgressCallback",
    "Runner",
    "Task",
    "TaskError",
    "resolve_runner",
]

#: ``progress(percent, message)``
ProgressCallback = Callable[[int, str], None]
Runner = Callable[
    [dict[str, Any], ProgressCallback, Callable[[], bool]], tuple[bytes, dict[str, Any]]
]


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


class Events(Protocol):
    """Where a backend reports; called on the event loop."""

    def started(self, job_id: str) -> None: ...

    def progress(self, job_id: str, percent: int, message: str) -> None: ...

    def finished(self, job_id: str, outcome: Outcome) -> None: ...


@dataclass(frozen=True)
class BackendStats:
    workers: int  #: configured
    alive: int  #: running worker processes
    busy: int  #: tasks running
    queued: int  #: tasks waiting for a worker
    ready: int = -1  #: workers warmed up and taking tasks (-1: not known to the backend)


class ComputeBackend(Protocol):
    """Runs tasks off the event loop."""

    name: str

    async def start(self, events: Events) -> None:
        """Start workers; events go to ``events`` from now on."""

    async def close(self) -> None:
        """Stop every worker; unfinished tasks end without an outcome (the store re-queues)."""

    def submit(self, task: Task) -> None:
        """Queue ``task``; a task of a job already queued or running is a programming error."""

    def cancel(self, job_id: str) -> None:
        """Drop a queued task or stop a running one (outcome ``cancelled``); unknown ids: no-op."""

    def alive(self) -> bool:
        """True while the backend can run tasks."""

    def stats(self) -> BackendStats: ...


def resolve_runner(name: str) -> Runner:
    """The function a task's ``runner`` names."""
    module, _, attr = name.partition(":")
    fn: Runner = getattr(importlib.import_module(module), attr)
    return fn
