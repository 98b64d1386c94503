"""What the backends that supervise workers of their own share (:mod:`.local`, :mod:`.inline`):
the tasks waiting for a worker and the sink their events go to, both on the event loop."""

from __future__ import annotations

import asyncio
from collections import deque

from ..task import Outcome, Task, handover_failed, queued_cancel
from .base import Events

__all__ = ["QueuedBackend"]


class QueuedBackend:
    """A queue of tasks in front of workers; subclasses start the workers, hand tasks to them
    (``_dispatch``) and stop a running one (``_stop_running``)."""

    def __init__(self) -> None:
        self._queue: deque[Task] = deque()
        self._events: Events | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._closing = False

    def _begin(self, events: Events) -> asyncio.AbstractEventLoop:
        """Report to ``events`` on the running loop from now on (called by ``start``)."""
        self._events = events
        self._loop = asyncio.get_running_loop()
        self._closing = False
        return self._loop

    def _require_loop(self) -> asyncio.AbstractEventLoop:
        if self._loop is None or self._events is None:
            raise RuntimeError("the backend is not started")
        return self._loop

    def submit(self, task: Task) -> None:
        self._require_loop()
        if self._closing:
            raise RuntimeError("the backend is closing")
        self._queue.append(task)
        self._dispatch()

    def cancel(self, job_id: str) -> None:
        loop = self._require_loop()
        for task in self._queue:
            if task.job_id == job_id:
                self._queue.remove(task)
                loop.call_soon(self._report, job_id, queued_cancel())
                return
        self._stop_running(job_id)

    def _report(self, job_id: str, outcome: Outcome) -> None:
        if self._events is not None:
            self._events.finished(job_id, outcome)

    def _refuse(self, task: Task, exc: Exception) -> None:
        """End a task that cannot be handed to a worker (its payload does not pickle: too deep,
        a foreign object) as an error at once: the task's fault, it never holds a worker."""
        self._require_loop().call_soon(self._report, task.job_id, handover_failed(exc))

    def _dispatch(self) -> None:
        """Hand waiting tasks to idle workers."""
        raise NotImplementedError

    def _stop_running(self, job_id: str) -> None:
        """Stop the running task of ``job_id``, if any (its outcome: ``cancelled``)."""
        raise NotImplementedError
