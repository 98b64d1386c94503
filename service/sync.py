"""Synchronous execution: the ``Prefer`` header (RFC 7240), waiting for a job's end without
blocking the event loop, and the execute response's outputs (``response`` and ``outputs``).

>>> parse_prefer("respond-async, wait=10")
{'respond-async': '', 'wait': '10'}
"""

from __future__ import annotations

import asyncio
import re
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from .formats import FORMATS, ResultFormat, StoredResult
from .jobs.store import FINAL, JobRecord, JobStatus, JobStore
from .jobs.task import FailureKind, unpack
from .problems import Problem
from .views import link

__all__ = [
    "Failure",
    "Preference",
    "failure",
    "job_problem",
    "output_format",
    "parse_prefer",
    "preference",
    "wait_final",
]

#: First and last pause between two looks at the store while a sync request waits.
_FIRST_POLL, _LAST_POLL = 0.01, 0.25


def parse_prefer(header: str | None) -> dict[str, str]:
    """The preferences of a ``Prefer`` header: name (lower case) -> value (``''`` if none).

    Parameters after ``;`` are ignored (none of ours has any); the first of a repeated name wins.
    """
    out: dict[str, str] = {}
    for item in (header or "").split(","):
        token = item.split(";", 1)[0].strip()
        if not token:
            continue
        name, _, value = token.partition("=")
        out.setdefault(name.strip().lower(), value.strip().strip('"'))
    return out


@dataclass(frozen=True)
class Preference:
    """How one execute request is answered."""

    wait: float | None  #: seconds to wait for the job's end; None: answer at once (async)
    applied: str | None  #: the ``Preference-Applied`` value, None when no preference applied


def preference(header: str | None, max_wait: float) -> Preference:
    """The execution mode asked by ``Prefer``: ``wait=N`` waits up to ``min(N, max_wait)`` s
    (with or without ``respond-async``, which is what happens when the wait runs out);
    ``respond-async`` alone answers at once; ``respond-sync`` (OWSLib's) waits the longest
    allowed; no header keeps the async default and applies nothing.

    >>> preference("wait=5", 60.0)
    Preference(wait=5.0, applied='wait=5')
    >>> preference("wait=500, respond-async", 60.0)
    Preference(wait=60.0, applied='wait=60')
    >>> preference("respond-async", 60.0), preference(None, 60.0)
    (Preference(wait=None, applied='respond-async'), Preference(wait=None, applied=None))
    >>> preference("respond-sync", 60.0)
    Preference(wait=60.0, applied='respond-sync')
    """
    prefs = parse_prefer(header)
    raw = prefs.get("wait")
    if raw is not None and raw.isdigit() and max_wait > 0:
        seconds = min(float(raw), max_wait)
        return Preference(seconds, f"wait={seconds:g}")
    if "respond-async" in prefs:
        return Preference(None, "respond-async")
    if "respond-sync" in prefs and max_wait > 0:  # not RFC 7240's, but what OWSLib sends
        return Preference(max_wait, "respond-sync")
    return Preference(None, None)


async def wait_final(store: JobStore, job_id: str, timeout: float) -> JobRecord | None:
    """The job's record once it is final, or its latest record when ``timeout`` s pass first.

    Polls the store (the job may finish in any worker or service process) with growing pauses,
    awaiting between looks, so the event loop is never blocked.
    """
    deadline = time.monotonic() + timeout
    pause = _FIRST_POLL
    while True:
        record = await asyncio.to_thread(store.get, job_id)
        left = deadline - time.monotonic()
        if record is None or record.status in FINAL or left <= 0:
            return record
        await asyncio.sleep(min(pause, left))
        pause = min(pause * 2, _LAST_POLL)


@dataclass(frozen=True)
class Failure:
    """A failed job's failure, as an HTTP problem."""

    status: int
    kind: str
    title: str


#: The failure kind a job keeps (set from how its run ended) -> its problem.
_BY_KIND: dict[str, Failure] = {
    kind: Failure(status, kind.value, title)
    for kind, status, title in (
        (FailureKind.invalid_input, 422, "Invalid input found while running"),
        (FailureKind.timeout, 422, "Job over the time limit"),
        (FailureKind.internal, 500, "Job failed on an internal error"),
        (FailureKind.crashed, 500, "Job crashed"),
        (FailureKind.backend, 503, "Backend unavailable"),
    )
}

#: A job failed before kinds were kept: the service's own failure messages (written by
#: ``service.jobs``) -> the kind they name, first match wins. Any other message is a runner's
#: ``TaskError``: the input's fault, found while running.
_OLD_MESSAGES: tuple[tuple[re.Pattern[str], FailureKind], ...] = tuple(
    (re.compile(pattern), kind)
    for pattern, kind in (
        (r"^stopped after exceeding the time limit", FailureKind.timeout),
        (r"^internal error: ", FailureKind.internal),
        # a crash (worker killed, out of memory) on the last attempt the settings allow
        (r"\(attempt \d+ of \d+\)$", FailureKind.crashed),
        (r"^interrupted on attempt ", FailureKind.crashed),
        (r"^the Dask scheduler at ", FailureKind.backend),
        (
            r"^(the (job|task) could not be handed to a worker|it could not be queued again"
            r"|its stored input cannot be read|process '.*' is not available"
            r"|stored with an unknown status)",
            FailureKind.internal,
        ),
    )
)


def failure(message: str, kind: str = "") -> Failure:
    """The failure of a job that failed with ``message`` and the failure ``kind`` it keeps; a
    job stored without a kind (or with one this version does not know) by its message.

    >>> failure("the region is empty", "limit-exceeded").status
    422
    >>> failure("out of memory (attempt 3 of 3)", "job-crashed").kind
    'job-crashed'
    >>> failure("stopped after exceeding the time limit of 2 s").kind
    'limit-exceeded'
    >>> failure("the boundary crosses itself near (0.5, 0.5)").kind
    'invalid-input'
    """
    named = _BY_KIND.get(kind)
    if named is not None:
        return named
    for pattern, old in _OLD_MESSAGES:
        if pattern.search(message):
            return _BY_KIND[old]
    return _BY_KIND[FailureKind.invalid_input]


def job_problem(base: str, record: JobRecord) -> Problem:
    """The problem answering a synchronous execution whose job ended without outputs: its
    failure (status from the failure's kind) or its dismissal, naming the job (``jobID``, a
    link to its status and the ``Location`` header)."""
    status_url = f"{base}/jobs/{record.id}"
    extra: dict[str, Any] = {
        "jobID": record.id,
        "links": [link(status_url, "status", title="the job")],
    }
    headers = {"Location": status_url}
    if record.status is JobStatus.dismissed:
        return Problem(
            410,
            "the job was dismissed before it ended",
            kind="job-dismissed",
            headers=headers,
            **extra,
        )
    named = failure(record.message, record.failure)
    return Problem(
        named.status,
        f"the job failed: {record.message}",
        kind=named.kind,
        title=named.title,
        headers=headers,
        **extra,
    )


def output_format(outputs: Mapping[str, Any] | None, known: Mapping[str, Any]) -> ResultFormat:
    """The format of the (single) output asked in an execute request's ``outputs``: checks the
    output ids (400 for an unknown one) and ``format.mediaType`` (400 for one not offered);
    the mesh document (json) when no format is asked."""
    chosen = FORMATS["json"]
    for output_id, spec in (outputs or {}).items():
        if output_id not in known:
            raise Problem(
                400,
                f"there is no output {output_id!r}; the outputs are {sorted(known)}",
                kind="invalid-parameter",
                parameter="outputs",
            )
        fmt = spec.get("format") if isinstance(spec, Mapping) else None
        media = fmt.get("mediaType") if isinstance(fmt, Mapping) else None
        if media is None:
            continue
        offered = {f.media_type: f for f in FORMATS.values() if f.writer is not None}
        if media not in offered:
            raise Problem(
                400,
                f"output {output_id!r} is not offered as {media!r}; choose one of"
                f" {sorted(offered)}",
                kind="invalid-parameter",
                parameter="outputs",
            )
        chosen = offered[media]
    return chosen


def render_output(blob: bytes, fmt: ResultFormat) -> bytes:
    """A stored result in ``fmt`` (with default options): CPU work, run it in a thread."""
    return fmt.render(StoredResult(unpack(blob)), {})
