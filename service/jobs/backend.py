"""The :class:`ComputeBackend` interface: something that runs tasks and reports what happened.

A backend runs :class:`Task` objects (a runner named ``"module:function"`` and its JSON payload)
somewhere else than the event loop and reports to an :class:`Events` sink, on the event loop:
``started`` once per run, ``progress`` any number of times, then exactly one ``finished`` with an
:class:`Outcome` for every task submitted, whether it succeeded, failed, crashed its worker, ran
out of time or was cancelled. Retrying is the caller's business. Every implementation passes the
contract suite in ``tests/service/test_backend_contract.py``.

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
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from ..settings import Settings

__all__ = [
    "BACKENDS",
    "BackendStats",
    "ComputeBackend",
    "Events",
    "Outcome",
    "OutcomeKind",
    "ProgressCallback",
    "Runner",
    "Task",
    "TaskError",
    "make_backend",
    "resolve_runner",
    "scheduler_security",
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


def _local(settings: Settings) -> ComputeBackend:
    from .local import LocalBackend

    return LocalBackend(
        workers=settings.workers, cancel_grace=settings.cancel_grace, nice=settings.worker_nice
    )


def _dask(settings: Settings) -> ComputeBackend:
    try:
        from .dask import DaskBackend
    except ImportError as exc:  # the optional extra is missing
        raise ValueError(
            f"the dask backend needs the dask extra (pip install 'evomesh[dask]'): {exc}"
        ) from exc
    return DaskBackend(
        settings.scheduler,
        workers=settings.workers,
        cancel_grace=settings.cancel_grace,
        stop_poll=settings.stop_poll,
        reconnect_timeout=settings.scheduler_timeout,
        security=scheduler_security(settings),
    )


def scheduler_security(settings: Settings) -> Any:
    """The TLS settings of the connection to a ``tls://`` Dask scheduler (None: plain TCP).

    With ``scheduler_tls_ca`` the scheduler's certificate is checked against that CA and
    encryption is required; ``scheduler_tls_cert`` and ``scheduler_tls_key`` are the service's
    client certificate, for schedulers that require one (mutual TLS).
    """
    paths = (settings.scheduler_tls_ca, settings.scheduler_tls_cert, settings.scheduler_tls_key)
    if all(p is None for p in paths):
        return None
    from distributed.security import Security

    ca, cert, key = (None if p is None else str(p) for p in paths)
    return Security(  # type: ignore[no-untyped-call]
        tls_ca_file=ca, tls_client_cert=cert, tls_client_key=key, require_encryption=True
    )


#: Backend factories by name (``Settings.backend``).
BACKENDS: dict[str, Callable[[Settings], ComputeBackend]] = {"local": _local, "dask": _dask}


def make_backend(settings: Settings) -> ComputeBackend:
    try:
        factory = BACKENDS[settings.backend]
    except KeyError:
        raise ValueError(
            f"backend {settings.backend!r} is not available; choose one of {sorted(BACKENDS)}"
        ) from None
    return factory(settings)
