"""``/processes``: the process list, their OGC descriptions, and execution (asynchronous by
default, synchronous with ``Prefer: wait=N``)."""

from collections.abc import Callable
from functools import partial
from typing import Annotated, Any, TypeVar

import anyio.to_thread
from fastapi import APIRouter, Header, Request
from fastapi.responses import JSONResponse, Response

from ..callbacks import CallbackNotifier
from ..deps import ManagerDep, OwnerDep, SettingsDep
from ..formats import FORMATS
from ..inputs import ExecuteRequest
from ..jobs.manager import request_digest
from ..jobs.store import IdempotencyConflict, JobStatus
from ..middleware import JsonBodyRoute, PoolAdmission, Then
from ..problems import Problem
from ..processes import PROCESSES, Prepared, Process, inputs_at
from ..processes.base import prepare_stored
from ..schemas import ProcessDescription, ProcessList, StatusInfo
from ..settings import Settings
from ..sync import job_problem, output_format, preference, render_output, wait_final
from ..views import base_url, link, status_info

_REL_EXECUTE = "http://www.opengis.net/def/rel/ogc/1.0/execute"


def _inline(schema: dict[str, Any], defs: dict[str, Any]) -> Any:
    """``schema`` with local ``$ref``s replaced by their definitions (OGC wants them inline)."""
    if isinstance(schema, dict):
        ref = schema.get("$ref")
        if isinstance(ref, str) and ref.startswith("#/$defs/"):
            return _inline(defs[ref.rsplit("/", 1)[1]], defs)
        return {k: _inline(v, defs) for k, v in schema.items() if k != "$defs"}
    if isinstance(schema, list):
        return [_inline(v, defs) for v in schema]
    return schema


def describe(process: Process, base: str) -> dict[str, Any]:
    """The OGC process description; input schemas come from the inputs model."""
    full = process.inputs_model.model_json_schema()
    defs = full.get("$defs", {})
    required = set(full.get("required", []))
    inputs = {}
    for name, prop in full["properties"].items():
        schema = _inline(prop, defs)
        inputs[name] = {
            "title": schema.pop("title", name),
            "description": schema.get("description", ""),
            "schema": schema,
            "minOccurs": 1 if name in required else 0,
            "maxOccurs": 1,
        }
    return {
        **summary(process),
        "inputs": inputs,
        "outputs": process.outputs,
        "links": _process_links(process, base),
    }


def summary(process: Process) -> dict[str, Any]:
    """The process summary, with the execution modes this router offers."""
    out = process.summary()
    out["jobControlOptions"] = ["sync-execute", *out["jobControlOptions"]]
    return out


def _process_links(process: Process, base: str) -> list[dict[str, Any]]:
    return [
        link(f"{base}/processes/{process.id}", "self", title="process description"),
        link(f"{base}/processes/{process.id}/execution", _REL_EXECUTE, title="execute"),
    ]


T = TypeVar("T")


async def off_loop(fn: Callable[..., T], *args: Any) -> T:
    """``fn(*args)`` in a thread: preparing a request parses the region and runs the engine's
    estimate, whose time depends on the shape, not only on the body's size."""
    return await anyio.to_thread.run_sync(fn, *args)


def _unknown(process_id: str, processes: dict[str, Process]) -> Problem:
    return Problem(
        404,
        f"there is no process {process_id!r}; the processes are {sorted(processes)}",
        kind="no-such-process",
    )


IdempotencyKey = Annotated[
    str | None,
    Header(
        alias="Idempotency-Key",
        max_length=255,
        pattern=r"^[\x21-\x7e]+$",
        description="the same key and body return the same job; a different body is a 422",
    ),
]

#: 429: too many jobs wait to start (``max_queued``); nothing was created.
QUEUE_FULL: dict[int | str, dict[str, Any]] = {
    429: {
        "description": "too many jobs are waiting to start; nothing was created",
        "headers": {
            "Retry-After": {"schema": {"type": "integer"}, "description": "seconds to wait"}
        },
    }
}

PreferHeader = Annotated[
    str | None,
    Header(
        alias="Prefer",
        max_length=200,
        description="RFC 7240: 'wait=N' waits up to N s (capped by the service) for the job's"
        " end and answers 200 with its outputs; 'respond-async' (the default) answers 201 at once",
        examples=["wait=30", "respond-async"],
    ),
]

_LOCATION = {"schema": {"type": "string"}, "description": "the job"}
_APPLIED = {"schema": {"type": "string"}, "description": "the Prefer preference applied, if any"}

_EXECUTE_RESPONSES: dict[int | str, dict[str, Any]] = {
    200: {
        "description": "the job ended within 'Prefer: wait=N': its outputs (response=document:"
        ' {"mesh": <mesh document>}; raw: the output itself in the format asked in outputs)',
        # document: JSON; raw: the output in any result format
        "content": {f.media_type: {} for f in FORMATS.values()},
        "headers": {"Location": _LOCATION, "Preference-Applied": _APPLIED},
    },
    201: {
        "model": StatusInfo,
        "description": "job created (or the job of a repeated Idempotency-Key)",
        "headers": {"Location": _LOCATION, "Preference-Applied": _APPLIED},
    },
    **QUEUE_FULL,
    # A synchronous execution whose job ended without outputs: the failure, naming the job.
    410: {"description": "the job was dismissed within 'Prefer: wait=N'"},
    422: {
        "description": "invalid input; or, within a wait, input found invalid while running"
        " or the job over the time limit"
    },
    500: {"description": "the job failed on an internal error or crashed within the wait"},
}


#: A large execute request's admission: the prepared job and the request's digest (when an
#: Idempotency-Key asks for one), or the problem that refuses it.
Admission = PoolAdmission[tuple[Prepared, str | None]]


def admit_body(
    process_id: str,
    prepare: Callable[[Any, Settings, Any], Prepared],
    settings: Settings,
    digest: bool,
    body: ExecuteRequest,
) -> tuple[ExecuteRequest, Admission]:
    """Run in a body pool process after validation: the whole admission of an execute request
    (parse, check the limits, estimate, encode the inputs as stored), so the event loop only
    hands bytes on. Returns the request without its inputs (all the handler reads of it) and
    the :data:`Admission`."""

    def admit() -> tuple[Prepared, str | None]:
        prepared = prepare_stored(prepare, body.inputs, settings, inputs_at("/inputs"))
        # The validated request (its depth bounded by the body reader), not the raw bytes: the
        # same JSON value in another key order is the same request.
        hashed = request_digest(process_id, body.model_dump(mode="json")) if digest else None
        return prepared, hashed

    admission = Admission.of(admit)
    # The inputs stay here: pickling them back would cost what the pool saved the loop.
    envelope = type(body).model_construct(
        inputs=None,  # type: ignore[arg-type]
        outputs=body.outputs,
        response=body.response,
        subscriber=body.subscriber,
    )
    return envelope, admission


class ExecuteRoute(JsonBodyRoute):
    """An execution route: a large body is admitted whole in the body pool (:func:`admit_body`)."""

    process: Process

    def pool_step(self, request: Request) -> Then | None:
        process = self.process
        keyed = "idempotency-key" in request.headers
        return partial(admit_body, process.id, process.prepare, request.app.state.settings, keyed)


def _route_class(process: Process) -> type[ExecuteRoute]:
    return type(f"Execute{process.id.title()}Route", (ExecuteRoute,), {"process": process})


def _execute_route(router: APIRouter, process: Process) -> None:
    model = process.execute_model

    async def execute(
        body: model,  # type: ignore[valid-type]
        request: Request,
        manager: ManagerDep,
        settings: SettingsDep,
        owner: OwnerDep,
        idempotency_key: IdempotencyKey = None,
        prefer: PreferHeader = None,
    ) -> Response:
        request_body: ExecuteRequest = body
        fmt = output_format(request_body.outputs, process.outputs)
        mode = preference(prefer, settings.max_sync_wait)
        callbacks: CallbackNotifier = request.app.state.callbacks
        if request_body.subscriber is not None:
            callbacks.check(request_body.subscriber)
        admitted: Admission | None = getattr(request.state, "prepared", None)
        if admitted is not None:  # a large body, admitted in the body pool
            prepared, digest = admitted.result()
        else:
            prepared = await off_loop(
                prepare_stored,
                process.prepare,
                request_body.inputs,
                settings,
                inputs_at("/inputs"),
            )
            # The validated request (its depth bounded by the body reader), not the raw
            # bytes: the same JSON value in another key order is the same request.
            digest = (
                request_digest(process.id, request_body.model_dump(mode="json"))
                if idempotency_key
                else None
            )
        try:
            record, created = await manager.submit(
                process,
                prepared,
                idempotency_key=idempotency_key,
                request_hash=digest,
                owner=owner,
            )
        except IdempotencyConflict as exc:
            raise Problem(
                422,
                f"the Idempotency-Key was used for a different request (job {exc.job_id})",
                kind="idempotency-conflict",
                title="Idempotency key reused",
            ) from None
        base = base_url(request)
        if created and request_body.subscriber is not None:  # before any await: no event missed
            await callbacks.subscribe(record.id, base, request_body.subscriber)
        headers = {"Location": f"{base}/jobs/{record.id}"}
        if mode.applied is not None:
            headers["Preference-Applied"] = mode.applied
        if not created:
            headers["Idempotent-Replayed"] = "true"
        if mode.wait is not None:
            record = await wait_final(manager.store, record.id, mode.wait) or record
            blob = await off_loop(manager.store.result, record.id)
            if blob is not None:
                if request_body.response == "raw":
                    raw = await off_loop(render_output, blob, fmt)
                    return Response(raw, media_type=fmt.media_type, headers=headers)
                # document: the outputs keyed by output id; the mesh document is JSON already
                mesh = await off_loop(render_output, blob, FORMATS["json"])
                return Response(
                    b'{"mesh":' + mesh + b"}", media_type="application/json", headers=headers
                )
            if record.status in (JobStatus.failed, JobStatus.dismissed):
                problem = job_problem(base, record)
                problem.headers.update(headers)
                raise problem
        # 201: the job is still running when the wait ended (or no wait was asked)
        return JSONResponse(status_info(base, record), status_code=201, headers=headers)

    router.add_api_route(
        f"/{process.id}/execution",
        execute,
        methods=["POST"],
        status_code=201,
        summary=f"Execute {process.id} (asynchronously, or synchronously with Prefer: wait=N)",
        response_model=None,
        responses=_EXECUTE_RESPONSES,
        operation_id=f"execute_{process.id}",
        route_class_override=_route_class(process),
    )


def build_router(processes: dict[str, Process] | None = None) -> APIRouter:
    """The ``/processes`` router for a set of processes (by default :data:`PROCESSES`)."""
    procs = PROCESSES if processes is None else processes
    router = APIRouter(prefix="/processes", tags=["Processes"], route_class=JsonBodyRoute)

    @router.get("", response_model=ProcessList, summary="The processes")
    def list_processes(request: Request) -> dict[str, Any]:
        base = base_url(request)
        return {
            "processes": [{**summary(p), "links": _process_links(p, base)} for p in procs.values()],
            "links": [link(f"{base}/processes", "self", title="processes")],
        }

    @router.get("/{processId}", response_model=ProcessDescription, summary="A process description")
    def get_process(processId: str, request: Request) -> dict[str, Any]:
        process = procs.get(processId)
        if process is None:
            raise _unknown(processId, procs)
        return describe(process, base_url(request))

    for process in procs.values():
        _execute_route(router, process)

    @router.post("/{processId}/execution", include_in_schema=False)
    def execute_unknown(processId: str) -> None:
        raise _unknown(processId, procs)

    return router
