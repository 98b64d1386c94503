"""The job list's OGC filters that the store does not index: ``datetime`` (on the job's creation),
``minDuration`` / ``maxDuration`` (seconds from start to end, or to now while running) and
``type``.

>>> f = JobFilter.parse("2026-01-01T00:00:00Z/..", None, None, None)
>>> f.created_after, f.created_before
(1767225600000, None)
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

from .jobs.store import JobRecord
from .problems import Problem

__all__ = ["JobFilter"]

#: The only job type this service has (OGC's ``type`` query parameter).
JOB_TYPES = frozenset({"process"})


_EPOCH = datetime(1970, 1, 1, tzinfo=UTC)
_MS = timedelta(milliseconds=1)


def millis(moment: datetime | float) -> int:
    """Whole milliseconds since the epoch, truncated as the documents write times
    (:func:`service.views.iso`), so a time read from a document matches its job exactly."""
    if not isinstance(moment, datetime):
        moment = datetime.fromtimestamp(moment, UTC)
    return (moment - _EPOCH) // _MS


def _instant(text: str) -> int:
    try:
        moment = datetime.fromisoformat(text)
    except ValueError:
        raise Problem(
            400,
            f"datetime {text!r} is not an RFC 3339 date-time",
            kind="invalid-parameter",
            parameter="datetime",
        ) from None
    if moment.tzinfo is None:  # RFC 3339 has an offset; a bare time is read as UTC
        moment = moment.replace(tzinfo=UTC)
    return millis(moment)


def _end(text: str) -> int | None:
    return None if text in ("", "..") else _instant(text)


@dataclass(frozen=True)
class JobFilter:
    """Bounds a job must satisfy; ``None`` is no bound."""

    created_after: int | None = None  #: milliseconds since the epoch
    created_before: int | None = None
    min_duration: float | None = None
    max_duration: float | None = None
    types: frozenset[str] | None = None

    @classmethod
    def parse(
        cls,
        when: str | None,
        min_duration: float | None,
        max_duration: float | None,
        types: Sequence[str] | None,
    ) -> JobFilter:
        """The filter of the query parameters; an instant ``datetime`` is an interval of one
        point, an interval is ``start/end`` with ``..`` (or nothing) for an open end.

        >>> JobFilter.parse("1970-01-01T00:00:10Z", None, None, None).created_before
        10000
        """
        after = before = None
        if when:
            if "/" in when:
                start, _, stop = when.partition("/")
                after, before = _end(start), _end(stop)
            else:
                after = before = _instant(when)
        return cls(after, before, min_duration, max_duration, frozenset(types) if types else None)

    @property
    def active(self) -> bool:
        """Whether any bound is set (else every job passes and the store pages alone)."""
        return any(
            v is not None
            for v in (
                self.created_after,
                self.created_before,
                self.min_duration,
                self.max_duration,
                self.types,
            )
        )

    def accepts(self, record: JobRecord, now: float | None = None) -> bool:
        """Whether ``record`` passes every bound (a duration bound needs a started job)."""
        if self.types is not None and not (self.types & JOB_TYPES):
            return False
        # Times have millisecond precision on the wire: compare at that precision.
        created = millis(record.created)
        if self.created_after is not None and created < self.created_after:
            return False
        if self.created_before is not None and created > self.created_before:
            return False
        if self.min_duration is None and self.max_duration is None:
            return True
        if record.started is None:
            return False
        end = record.finished if record.finished is not None else (now or time.time())
        duration = end - record.started
        if self.min_duration is not None and duration < self.min_duration:
            return False
        return self.max_duration is None or duration <= self.max_duration

    def page(
        self,
        search: Callable[[int, int], tuple[list[JobRecord], int]],
        limit: int,
        offset: int,
        chunk: int = 1000,
    ) -> tuple[list[JobRecord], int]:
        """``limit`` matching jobs from ``offset`` and how many match, reading the store's
        pages (``search(limit, offset)``, newest first) in chunks."""
        matched: list[JobRecord] = []
        total = 0
        start = 0
        now = time.time()
        while True:
            records, _ = search(chunk, start)
            for record in records:
                if self.accepts(record, now):
                    if offset <= total < offset + limit:
                        matched.append(record)
                    total += 1
            if len(records) < chunk:
                return matched, total
            start += chunk
