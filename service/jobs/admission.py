"""Backpressure: how many jobs may wait to start, and when a refused client should come back.

Beyond ``max_queued`` waiting jobs, execution and batches are refused whole with 429 and a
``Retry-After`` estimated from how fast jobs have been leaving the queue lately.

>>> clock = iter([0.0, 10.0, 11.0, 12.0, 12.0, 30.0]).__next__
>>> rate = Throughput(window=10.0, clock=clock)  # created at 0
>>> rate.record(); rate.record(); rate.record()  # at 10, 11 and 12
>>> rate.per_second()  # at 12: three in the last 10 s
0.3
>>> rate.per_second()  # at 30: none in the last 10 s
0.0
>>> retry_after(excess=10, per_second=2.0)
5
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable

__all__ = ["QueueFull", "Throughput", "retry_after"]

#: Bounds of a ``Retry-After`` (seconds).
RETRY_MIN, RETRY_MAX = 1, 60
#: ``Retry-After`` when nothing has left the queue lately to estimate from.
RETRY_UNKNOWN = 5


class QueueFull(Exception):
    """Too many jobs are waiting to start for ``wanted`` more to be accepted now."""

    def __init__(self, waiting: int, limit: int, wanted: int, retry_after: int) -> None:
        jobs = "a job" if wanted == 1 else f"{wanted} jobs"
        are = "job is" if waiting == 1 else "jobs are"
        super().__init__(
            f"{waiting} {are} waiting to start and at most {limit} may wait: {jobs} cannot be"
            f" accepted now; try again in {retry_after} s"
        )
        self.waiting = waiting
        self.limit = limit
        self.wanted = wanted
        self.retry_after = retry_after


class Throughput:
    """Jobs leaving the queue (finished, failed, dismissed) per second over the last
    ``window`` seconds."""

    def __init__(
        self, window: float = 30.0, clock: Callable[[], float] = time.monotonic, keep: int = 10_000
    ) -> None:
        self.window = window
        self._clock = clock
        self._times: deque[float] = deque(maxlen=keep)
        self._since = clock()  #: a young service measures over its life, not the whole window

    def record(self) -> None:
        self._times.append(self._clock())

    def per_second(self) -> float:
        now = self._clock()
        while self._times and now - self._times[0] > self.window:
            self._times.popleft()
        if not self._times:
            return 0.0
        span = min(self.window, now - self._since)
        if len(self._times) == self._times.maxlen:  # full: the oldest kept time bounds the span
            span = now - self._times[0]
        return len(self._times) / max(span, 1.0)


def retry_after(excess: int, per_second: float) -> int:
    """Seconds until ``excess`` jobs have left the queue at ``per_second``, within bounds."""
    if per_second <= 0:
        return RETRY_UNKNOWN
    return max(RETRY_MIN, min(RETRY_MAX, math.ceil(excess / per_second)))
