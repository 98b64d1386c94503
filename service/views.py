"""Building the OGC documents (status info, batch info, links) from store records."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, datetime
from typing import Any

from starlette.requests import Request

from .formats import FORMATS
from .jobs.store import FINAL, BatchRecord, JobRecord, JobStatus

__all__ = ["batch_info", "iso", "link", "status_info"]

REL_RESULTS = "http://www.opengis.net/def/rel/ogc/1.0/results"
REL_PROCESS = "http://www.opengis.net/def/rel/ogc/1.0/processes"


def iso(t: float | None) -> str | None:
    """RFC 3339 UTC time of seconds since the epoch.

    >>> iso(0.0)
    '1970-01-01T00:00:00.000Z'
    """
    if t is None:
        return None
    return datetime.fromtimestamp(t, UTC).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"


def link(
    href: str, rel: str, type: str = "application/json", title: str | None = None
) -> dict[str, Any]:
    out = {"href": href, "rel": rel, "type": type}
    if title:
        out["title"] = title
    return out


def base_url(request: Request) -> str:
    """The service's base URL for links: the configured ``public_url``, else the request's own
    (whose Host the trusted-hosts check has accepted)."""
    public: str | None = request.app.state.settings.public_url
    return (public or str(request.base_url)).rstrip("/")


def job_links(base: str, record: JobRecord) -> list[dict[str, Any]]:
    links = [
        link(f"{base}/jobs/{record.id}", "self", title="status"),
        link(f"{base}/processes/{record.process}", "up", title="process description"),
    ]
    if record.status is JobStatus.successful:
        # one link per media type offered (OGC: rel results, with its type); the mesh document
        # first, at the address without a query
        results = f"{base}/jobs/{record.id}/results"
        for fmt in FORMATS.values():
            if fmt.writer is not None:
                href = results if fmt.name == "json" else f"{results}?f={fmt.name}"
                links.append(link(href, REL_RESULTS, fmt.media_type, f"results ({fmt.name})"))
    return links


def status_info(base: str, record: JobRecord) -> dict[str, Any]:
    """The OGC statusInfo document of a job."""
    return {
        "jobID": record.id,
        "processID": record.process,
        "type": "process",
        "status": record.status.value,
        "message": record.message,
        "created": iso(record.created),
        # OGC's statusInfo types these as date-time (never null): absent until they happen
        **{
            k: iso(v)
            for k, v in (("started", record.started), ("finished", record.finished))
            if v is not None
        },
        "updated": iso(record.updated),
        "progress": record.progress,
        "attempts": record.attempts,
        "seed": record.seed,
        "links": job_links(base, record),
    }


def aggregate(statuses: Sequence[JobStatus]) -> JobStatus:
    """One status for many jobs: accepted until one starts, running until all are final; then
    failed if any failed, dismissed if all were dismissed, else successful.

    >>> aggregate([JobStatus.successful, JobStatus.accepted])
    <JobStatus.running: 'running'>
    """
    if not statuses or all(s is JobStatus.accepted for s in statuses):
        return JobStatus.accepted
    if any(s not in FINAL for s in statuses):
        return JobStatus.running
    if any(s is JobStatus.failed for s in statuses):
        return JobStatus.failed
    if all(s is JobStatus.dismissed for s in statuses):
        return JobStatus.dismissed
    return JobStatus.successful


def batch_info(base: str, batch: BatchRecord, records: Sequence[JobRecord]) -> dict[str, Any]:
    """The batch document: the aggregated status, counts per status and every job's links."""
    counts = {s.value: 0 for s in JobStatus}
    for r in records:
        counts[r.status.value] += 1
    progress = round(
        sum(100 if r.status in FINAL else r.progress for r in records) / max(1, len(records))
    )
    return {
        "batchID": batch.id,
        "processID": batch.process,
        "status": aggregate([r.status for r in records]).value,
        "created": iso(batch.created),
        "progress": progress,
        "counts": counts,
        "jobs": [
            {
                "jobID": r.id,
                "status": r.status.value,
                "progress": r.progress,
                "links": job_links(base, r),
            }
            for r in records
        ],
        "links": [link(f"{base}/batches/{batch.id}", "self", title="batch status")],
    }
