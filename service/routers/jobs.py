"""``/jobs``: the job list, status documents, dismissal and results."""

from __future__ import annotations

import asyncio
from typing import Annotated

from fastapi import APIRouter, Depends, Query, Request, Response
from fastapi.responses import JSONResponse

from ..deps import ManagerDep, OwnerDep, SettingsDep, StoreDep, require_api_key
from ..formats import FORMATS, ResultFormat, StoredResult
from ..jobfilter import JobFilter
from ..jobs.store import JobRecord, JobStatus, JobStore
from ..jobs.task import unpack
from ..negotiate import acceptable, etag, etag_matches
from ..problems import Problem
from ..render import PictureError, RenderPool, picture_options
from ..schemas import JobList, StatusInfo
from ..views import base_url, link, status_info

#: Formats that are pictures (their options are checked, and bounded, before loading).
PICTURES = frozenset({"png", "svg"})

router = APIRouter(prefix="/jobs", tags=["Jobs"], dependencies=[Depends(require_api_key)])


def _job(store: JobStore, job_id: str, owner: str) -> JobRecord:
    """The owner's job; another owner's is not there for them (404, as if unknown)."""
    record = store.get(job_id)
    if record is None or record.owner != owner:
        raise Problem(404, f"there is no job {job_id!r}", kind="no-such-job")
    return record


@router.get("", response_model=JobList, summary="The jobs, newest first")
async def list_jobs(
    request: Request,
    store: StoreDep,
    owner: OwnerDep,
    status: Annotated[list[JobStatus] | None, Query(description="only these statuses")] = None,
    processID: Annotated[
        list[str] | None, Query(description="only jobs of these processes")
    ] = None,
    limit: Annotated[int, Query(ge=1, le=1000)] = 10,
    offset: Annotated[int, Query(ge=0, le=2**62)] = 0,
    datetime: Annotated[
        str | None,
        Query(
            max_length=100,
            description="jobs created at this RFC 3339 instant or in this interval"
            " ('start/end', '..' for an open end)",
        ),
    ] = None,
    minDuration: Annotated[
        float | None, Query(ge=0, description="jobs that ran at least this many seconds")
    ] = None,
    maxDuration: Annotated[
        float | None, Query(ge=0, description="jobs that ran at most this many seconds")
    ] = None,
    type: Annotated[
        list[str] | None, Query(max_length=32, description="job types ('process')")
    ] = None,
) -> JSONResponse:
    bounds = JobFilter.parse(datetime, minDuration, maxDuration, type)

    def search(size: int, start: int) -> tuple[list[JobRecord], int]:
        return store.search(
            status=status or (), process=processID or (), owner=owner, limit=size, offset=start
        )

    if bounds.active:  # filters the store does not index: read its pages off the loop
        records, total = await asyncio.to_thread(bounds.page, search, limit, offset)
    else:
        records, total = search(limit, offset)
    base = base_url(request)
    url = request.url

    def page(start: int) -> str:
        return str(url.include_query_params(limit=limit, offset=start))

    links = [link(str(url), "self", title="this page")]
    if offset + limit < total:
        links.append(link(page(offset + limit), "next", title="next page"))
    if offset > 0:
        links.append(link(page(max(0, offset - limit)), "prev", title="previous page"))
    body = {
        "jobs": [status_info(base, r) for r in records],
        "numberMatched": total,
        "links": links,
    }
    return JSONResponse(body)


@router.get("/{jobId}", summary="A job's status", responses={200: {"model": StatusInfo}})
async def get_job(jobId: str, request: Request, store: StoreDep, owner: OwnerDep) -> JSONResponse:
    # Answered straight from the store, without response-model validation: this is the request
    # clients poll, so it must stay fast while workers are busy.
    return JSONResponse(status_info(base_url(request), _job(store, jobId, owner)))


@router.delete(
    "/{jobId}",
    summary="Dismiss a job: a queued one never runs, a running one stops, results are deleted",
    responses={200: {"model": StatusInfo}},
)
async def dismiss_job(
    jobId: str, request: Request, manager: ManagerDep, owner: OwnerDep
) -> JSONResponse:
    _job(manager.store, jobId, owner)
    record = manager.dismiss(jobId)
    if record is None:
        raise Problem(404, f"there is no job {jobId!r}", kind="no-such-job")
    request.app.state.callbacks.changed(jobId)  # a dismissed job is called back no more
    return JSONResponse(status_info(base_url(request), record))


def _not_ready(record: JobRecord) -> Problem:
    if record.status is JobStatus.failed:
        return Problem(
            409, f"the job failed: {record.message}", kind="job-failed", title="Job failed"
        )
    if record.status is JobStatus.dismissed:
        return Problem(410, "the job was dismissed; it has no results", kind="job-dismissed")
    return Problem(
        404,
        f"the job is {record.status.value} ({record.progress}%); its results are not ready",
        kind="result-not-ready",
    )


#: Clients may keep a result but must ask again before using it: a dismissed or purged job's
#: results are gone (410/404), which only a revalidation (cheap: 304) can tell them.
RESULT_CACHE_CONTROL = "private, no-cache"


@router.get(
    "/{jobId}/results",
    summary="A job's results: the mesh document, or another format with f= or Accept",
    response_class=Response,
    responses={
        200: {
            "description": "the result in the requested format",
            "content": {f.media_type: {} for f in FORMATS.values()},
            "headers": {
                "ETag": {"schema": {"type": "string"}, "description": "for If-None-Match"},
                "Cache-Control": {"schema": {"type": "string"}},
            },
        },
        304: {"description": "not modified (If-None-Match matched the ETag)"},
        404: {"description": "no such job, or its results are not ready yet"},
        406: {"description": "no format offered matches Accept"},
        409: {"description": "the job failed: it has no results"},
        410: {"description": "the job was dismissed: its results were deleted"},
    },
)
async def get_results(
    jobId: str,
    request: Request,
    store: StoreDep,
    owner: OwnerDep,
    settings: SettingsDep,
    f: Annotated[
        str | None,
        Query(
            description=f"result format: {' | '.join(FORMATS)}; without it, Accept chooses",
            max_length=32,
        ),
    ] = None,
) -> Response:
    fmt = _result_format(f, request.headers.get("accept"))
    if fmt.name in PICTURES:  # checked before anything is loaded
        try:
            picture_options(request.query_params, settings.max_picture_pixels)
        except PictureError as exc:
            raise Problem(
                400, exc.message, kind="invalid-parameter", parameter=exc.parameter
            ) from None
    record = _job(store, jobId, owner)
    if record.status is not JobStatus.successful:
        raise _not_ready(record)
    options = tuple(sorted(request.query_params.multi_items()))
    tag = etag((jobId, record.finished, fmt.name, options))
    headers = {
        "Content-Disposition": f'inline; filename="{jobId}{fmt.extension}"',
        "ETag": tag,
        "Cache-Control": RESULT_CACHE_CONTROL,
        "Vary": "Accept, Accept-Encoding",
    }
    if etag_matches(request.headers.get("if-none-match"), tag):
        return Response(status_code=304, headers=headers)
    pool: RenderPool = request.app.state.render_pool
    key = (jobId, fmt.name, options)
    if fmt.name != "json" and (cached := pool.cached(key)) is not None:
        return Response(cached, media_type=fmt.media_type, headers=headers)
    blob = await asyncio.to_thread(store.result, jobId)
    if blob is None:  # dismissed or purged a moment ago
        raise _not_ready(_job(store, jobId, owner))
    if fmt.name == "json" and "deflate" in request.headers.get("accept-encoding", ""):
        # Stored as zlib, which is HTTP's "deflate": send it as it is.
        headers["Content-Encoding"] = "deflate"
        return Response(blob, media_type=fmt.media_type, headers=headers)

    def render() -> bytes:
        return fmt.render(StoredResult(unpack(blob)), request.query_params)

    if fmt.name == "json":
        body = await asyncio.to_thread(render)
    else:  # pictures and mesh files: bounded, and made once per job and options
        body = await pool.render(key, render)
    return Response(body, media_type=fmt.media_type, headers=headers)


def _result_format(f: str | None, accept: str | None) -> ResultFormat:
    """The format named by ``f``, else the best one ``Accept`` takes (400 / 406 otherwise)."""
    if f is not None:
        fmt = FORMATS.get(f)
        if fmt is None:
            raise Problem(
                400,
                f"unknown format {f!r}; choose one of {sorted(FORMATS)}",
                kind="invalid-parameter",
                parameter="f",
            )
        return fmt
    chosen = acceptable(accept)
    if not chosen:
        offered = sorted(x.media_type for x in FORMATS.values() if x.writer is not None)
        raise Problem(
            406,
            f"no result format matches Accept {accept!r}; the media types are {offered}",
            kind="not-acceptable",
        )
    return chosen[0]
