"""``/jobs``: the job list, status documents, dismissal and results."""

from __future__ import annotations

import asyncio
from typing import Annotated

from fastapi import APIRouter, Depends, Query, Request, Response
from fastapi.responses import JSONResponse

from ..deps import ManagerDep, OwnerDep, SettingsDep, StoreDep, require_api_key
from ..formats import FORMATS, StoredResult
from ..jobs.runners import unpack
from ..jobs.store import JobRecord, JobStatus, JobStore
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
) -> JSONResponse:
    records, total = store.search(
        status=status or (), process=processID or (), owner=owner, limit=limit, offset=offset
    )
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


@router.get(
    "/{jobId}/results",
    summary="A job's results: the mesh document, or another format with f=",
    response_class=Response,
    responses={
        200: {
            "description": "the result in the requested format",
            "content": {f.media_type: {} for f in FORMATS.values()},
        }
    },
)
async def get_results(
    jobId: str,
    request: Request,
    store: StoreDep,
    owner: OwnerDep,
    settings: SettingsDep,
    f: Annotated[
        str, Query(description=f"result format: {' | '.join(FORMATS)}", max_length=32)
    ] = "json",
) -> Response:
    fmt = FORMATS.get(f)
    if fmt is None:
        raise Problem(
            400,
            f"unknown format {f!r}; choose one of {sorted(FORMATS)}",
            kind="invalid-parameter",
            parameter="f",
        )
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
    headers = {"Content-Disposition": f'inline; filename="{jobId}{fmt.extension}"'}
    pool: RenderPool = request.app.state.render_pool
    key = (jobId, fmt.name, tuple(sorted(request.query_params.multi_items())))
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
