"""``/batches``: many jobs in one request (a FeatureCollection, or execute requests sharing
defaults), created together and followed together."""

from __future__ import annotations

from collections.abc import Mapping
from functools import partial
from typing import Any, Literal

from fastapi import APIRouter, Depends, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..deps import ManagerDep, OwnerDep, SettingsDep, require_api_key
from ..jobs.manager import JobManager
from ..jobs.store import BatchRecord
from ..middleware import JsonBodyRoute, PoolAdmission, Then
from ..problems import Problem
from ..processes import Prepared, Process, Where, inputs_at
from ..processes.base import prepare_stored
from ..schemas import BatchInfo
from ..settings import Settings
from ..views import base_url, batch_info
from .processes import QUEUE_FULL, off_loop

router = APIRouter(
    prefix="/batches",
    tags=["Batches"],
    dependencies=[Depends(require_api_key)],
    route_class=JsonBodyRoute,
)


class BatchRequest(BaseModel):
    """Either a GeoJSON FeatureCollection (one ``mesh`` job per feature; ``inputs`` holds the
    shared parameters, a feature's ``h`` property its size) or ``requests``: execute requests
    whose ``inputs`` are laid over the shared ``inputs``."""

    # GeoJSON foreign members (bbox, name...) are accepted and dropped, never kept.
    model_config = ConfigDict(extra="ignore", strict=True)

    type: Literal["FeatureCollection"] | None = None
    features: list[dict[str, Any]] | None = Field(None, min_length=1)
    process: str = Field("mesh", description="the process every job runs")
    inputs: dict[str, Any] = Field(default_factory=dict, description="shared inputs")
    requests: list[dict[str, Any]] | None = Field(None, min_length=1)

    @model_validator(mode="after")
    def _one_form(self) -> BatchRequest:
        if (self.features is None) == (self.requests is None):
            raise ValueError("give either a FeatureCollection's features or requests, not both")
        return self


def merge(defaults: dict[str, Any], given: dict[str, Any]) -> dict[str, Any]:
    """``given`` laid over ``defaults``, objects merged key by key.

    >>> merge({"size": 1, "smoothing": {"method": "none", "seed": 1}}, {"smoothing": {"seed": 2}})
    {'size': 1, 'smoothing': {'method': 'none', 'seed': 2}}
    """
    out = dict(defaults)
    for key, value in given.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge(out[key], value)
        else:
            out[key] = value
    return out


def _items(body: BatchRequest) -> list[tuple[dict[str, Any], tuple[Any, ...], Where]]:
    """Each job's inputs, where validation errors point, and where its inputs are."""
    out: list[tuple[dict[str, Any], tuple[Any, ...], Where]] = []
    if body.features is not None:
        for i, feature in enumerate(body.features):

            def where(name: str, i: int = i) -> str:
                return f"/features/{i}" if name == "boundary" else f"/inputs/{name}"

            out.append((merge(body.inputs, {"boundary": feature}), ("features", i), where))
    else:
        assert body.requests is not None
        for i, request in enumerate(body.requests):
            given = request.get("inputs", {})
            if not isinstance(given, dict):
                raise RequestValidationError(
                    [{"loc": ("body", "requests", i, "inputs"), "msg": "inputs must be an object"}]
                )
            out.append(
                (
                    merge(body.inputs, given),
                    ("requests", i, "inputs"),
                    inputs_at(f"/requests/{i}/inputs"),
                )
            )
    return out


def _check(body: BatchRequest, processes: Mapping[str, Process], settings: Settings) -> Process:
    """The batch's process, once its form and size are within the limits (else a problem)."""
    process = processes.get(body.process)
    if process is None:
        raise Problem(
            404, f"there is no process {body.process!r}", kind="no-such-process", pointer="/process"
        )
    if body.features is not None and process.id != "mesh":
        raise Problem(
            422,
            "a FeatureCollection batch runs the mesh process",
            kind="invalid-input",
            pointer="/process",
        )
    count = _count(body)
    pointer = "/features" if body.features is not None else "/requests"
    if count > settings.max_batch_items:
        raise Problem(
            422,
            f"the batch has {count} items, over the limit of {settings.max_batch_items}",
            kind="limit-exceeded",
            pointer=pointer,
        )
    if count > settings.max_queued:
        raise Problem(
            422,
            f"the batch has {count} items, more than the {settings.max_queued} jobs that may wait"
            " to start (max_queued); split it",
            kind="limit-exceeded",
            pointer=pointer,
        )
    return process


def _count(body: BatchRequest) -> int:
    return len(body.features or body.requests or [])


def _prepare_all(body: BatchRequest, process: Process, settings: Settings) -> list[Prepared]:
    """Every item prepared, its inputs in their stored form (bytes): where this runs (a thread,
    a body pool process) encodes them, never the event loop."""
    prepared = []
    for inputs, loc, where in _items(body):
        try:
            model = process.inputs_model.model_validate(inputs)
        except ValidationError as exc:
            errors = []
            for err in exc.errors():
                path = list(err["loc"])
                if loc[0] == "features" and path[:1] == ["boundary"]:
                    path = path[1:]  # the feature is the boundary
                errors.append({"loc": ("body", *loc, *path), "msg": err["msg"]})
            raise RequestValidationError(errors) from None
        prepared.append(prepare_stored(process.prepare, model, settings, where))
    return prepared


#: A large batch's admission: the process id and every item prepared (inputs encoded), or the
#: problem that refuses the batch.
BatchAdmission = PoolAdmission[tuple[str, list[Prepared]]]


def admit_batch(
    processes: Mapping[str, Process], settings: Settings, body: BatchRequest
) -> tuple[BatchRequest, BatchAdmission]:
    """Run in a body pool process after validation: the whole admission of a batch (its limits,
    every item parsed, checked, estimated and encoded as stored), so the event loop only hands
    bytes on. Returns the request without its items (the handler reads only its process and
    count) and the :data:`BatchAdmission`."""

    def admit() -> tuple[str, list[Prepared]]:
        process = _check(body, processes, settings)
        return process.id, _prepare_all(body, process, settings)

    admission = BatchAdmission.of(admit)
    # The items stay here: pickling them back would cost what the pool saved the loop. (An
    # empty list of requests, not none: the model's one-form check runs again on the loop.)
    envelope = BatchRequest.model_construct(
        type=None, features=None, requests=[], process=body.process, inputs={}
    )
    return envelope, admission


class BatchRoute(JsonBodyRoute):
    """The batch route: a large body is admitted whole in the body pool (:func:`admit_batch`)."""

    def pool_step(self, request: Request) -> Then | None:
        manager: JobManager | None = getattr(request.app.state, "manager", None)
        if manager is None:  # not running: the handler's dependency answers 503
            return None
        return partial(admit_batch, manager.processes, request.app.state.settings)


async def create_batch(
    body: BatchRequest,
    request: Request,
    manager: ManagerDep,
    settings: SettingsDep,
    owner: OwnerDep,
) -> JSONResponse:
    admitted: BatchAdmission | None = getattr(request.state, "prepared", None)
    if admitted is not None:  # a large body, admitted in the body pool
        process_id, prepared = admitted.result()
        process = manager.processes[process_id]
    else:
        process = _check(body, manager.processes, settings)
        # refuse early, before the work of preparing every item
        manager.admit(process.id, _count(body), owner)
        prepared = await off_loop(_prepare_all, body, process, settings)
    batch = await manager.submit_batch(process, prepared, owner)
    base = base_url(request)
    doc = batch_info(base, batch, manager.store.records(batch.job_ids))
    return JSONResponse(doc, status_code=201, headers={"Location": f"{base}/batches/{batch.id}"})


router.add_api_route(
    "",
    create_batch,
    methods=["POST"],
    status_code=201,
    summary="Create a batch of jobs (all or none)",
    response_model=None,
    responses={
        201: {"model": BatchInfo, "headers": {"Location": {"schema": {"type": "string"}}}},
        **QUEUE_FULL,
    },
    route_class_override=BatchRoute,
)


def _batch(manager: JobManager, batch_id: str, owner: str) -> BatchRecord:
    """The owner's batch; another owner's is not there for them (404, as if unknown)."""
    batch = manager.store.batch(batch_id)
    if batch is None or batch.owner != owner:
        raise Problem(404, f"there is no batch {batch_id!r}", kind="no-such-batch")
    return batch


def _batch_doc(request: Request, manager: JobManager, batch_id: str, owner: str) -> dict[str, Any]:
    batch = _batch(manager, batch_id, owner)
    return batch_info(base_url(request), batch, manager.store.records(batch.job_ids))


@router.get(
    "/{batchId}", summary="A batch's aggregated status", responses={200: {"model": BatchInfo}}
)
async def get_batch(
    batchId: str, request: Request, manager: ManagerDep, owner: OwnerDep
) -> JSONResponse:
    return JSONResponse(_batch_doc(request, manager, batchId, owner))


@router.delete(
    "/{batchId}", summary="Dismiss every job of a batch", responses={200: {"model": BatchInfo}}
)
async def dismiss_batch(
    batchId: str, request: Request, manager: ManagerDep, owner: OwnerDep
) -> JSONResponse:
    batch = _batch(manager, batchId, owner)
    for job_id in batch.job_ids:
        manager.dismiss(job_id)
    return JSONResponse(_batch_doc(request, manager, batchId, owner))
