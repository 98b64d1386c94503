"""The :class:`ComputeBackend` interface: something that runs tasks and reports what happened.

A backend runs :class:`~service.jobs.task.Task` objects somewhere else than the event loop (the
task and its runners: :mod:`service.jobs.task`) and reports to an :class:`Events` sink, on the
event loop: ``started`` once per run, ``progress`` any number of times, then exactly one
``finished`` with an :class:`~service.jobs.task.Outcome` for every task submitted, whether it
succeeded, failed, crashed its worker, ran out of time or was cancelled. Retrying is the
caller's business. Every implementation passes the contract suite in
``tests/service/jobs/test_backend_contract.py``; :mod:`service.jobs.factory` builds one from the
settings (this interface imports no implementation).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from ..task import Outcome, Task

__all__ = ["BackendStats", "ComputeBackend", "Events"]


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
