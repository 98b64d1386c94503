"""The FastAPI application factory.

>>> from service.settings import Settings
>>> app = create_app(Settings(workers=1, _env_file=None))
>>> app.title
'evomesh'
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from starlette.middleware.gzip import GZipMiddleware

from . import problems
from .callbacks import CallbackNotifier
from .jobs.backends.base import ComputeBackend
from .jobs.factory import make_backend
from .jobs.manager import JobManager
from .jobs.sqlite import SqliteJobStore
from .jobs.store import JobStore
from .metrics import Metrics
from .middleware import BodyLimit, TrustedHosts, body_pool
from .openapi import complete, to_openapi30
from .processes import PROCESSES, Process
from .render.pool import RenderPool
from .routers import batches, docs, jobs, landing, viewer
from .routers.processes import build_router
from .settings import Settings

__all__ = ["create_app"]

_PROBLEM_REF = {"$ref": "#/components/schemas/ProblemDetails"}
#: Responses smaller than this are sent as they are.
GZIP_MINIMUM_BYTES = 1024


def create_app(
    settings: Settings,
    *,
    processes: dict[str, Process] | None = None,
    store: JobStore | None = None,
    backend: ComputeBackend | None = None,
) -> FastAPI:
    """The service. The store and backend are built from ``settings`` unless given; both are
    started and stopped by the app's lifespan."""
    procs = PROCESSES if processes is None else processes

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        job_store = store if store is not None else _open_store(settings)
        compute = backend if backend is not None else make_backend(settings)
        manager = JobManager(job_store, compute, settings, app.state.metrics, procs)
        collector = app.state.metrics.watch(job_store.counts, compute.stats)
        notifier = CallbackNotifier(job_store, settings)
        manager.on_change.append(notifier.changed)
        await notifier.start()
        await manager.start()
        app.state.manager = manager
        app.state.callbacks = notifier
        app.state.body_pool = body_pool(settings.body_workers)
        try:
            yield
        finally:
            app.state.manager = None
            if app.state.body_pool is not None:
                app.state.body_pool.shutdown(cancel_futures=True)
                app.state.body_pool = None
            await manager.close()
            await notifier.close()
            app.state.metrics.registry.unregister(collector)
            if store is None:
                job_store.close()

    app = FastAPI(
        title="evomesh",
        summary="Triangular meshing with genetic-algorithm smoothing (OGC API - Processes)",
        version="1.0.0",
        lifespan=lifespan,
        docs_url=None,  # served by routers.docs from vendored assets (FastAPI's loads a CDN)
        redoc_url=None,
    )
    app.state.settings = settings
    app.state.metrics = Metrics()
    app.state.manager = None
    app.state.body_pool = None
    app.state.render_pool = RenderPool(settings.render_workers, settings.render_cache_bytes)
    problems.install(app)
    app.include_router(landing.router)
    app.include_router(build_router(procs))
    app.include_router(jobs.router)
    app.include_router(batches.router)
    app.include_router(docs.router)
    viewer.install(app)
    if settings.cors_origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=settings.cors_origins,
            allow_methods=["GET", "POST", "DELETE"],
            allow_headers=[
                "Content-Type",
                "Authorization",
                "X-API-Key",
                "Idempotency-Key",
                "Prefer",
                "If-None-Match",
            ],
            expose_headers=["Location", "Preference-Applied", "ETag"],
        )
    # JSON, GeoJSON and the mesh files compress well; small answers are not worth it. Responses
    # already encoded (the stored mesh document sent as deflate) are left alone.
    app.add_middleware(GZipMiddleware, minimum_size=GZIP_MINIMUM_BYTES)
    app.add_middleware(BodyLimit, max_bytes=settings.max_body_bytes)
    if settings.trusted_hosts:
        # Links and Location headers are built from the Host header unless public_url is set:
        # a Host the operator did not list is refused, never echoed.
        app.add_middleware(TrustedHosts, allowed_hosts=settings.trusted_hosts)
    _document_problems(app)
    return app


def _open_store(settings: Settings) -> JobStore:
    return SqliteJobStore(settings.database)


def _document_problems(app: FastAPI) -> None:
    """Every error response of the OpenAPI document is problem+json (that is what we send); the
    document is completed (security, enums) and served as OpenAPI 3.0."""
    build = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is not None:
            return app.openapi_schema
        schema = build()
        from .schemas import ProblemDetails

        components = schema.setdefault("components", {}).setdefault("schemas", {})
        components["ProblemDetails"] = ProblemDetails.model_json_schema()
        for name in ("HTTPValidationError", "ValidationError"):
            components.pop(name, None)
        complete(schema)
        for path in schema.get("paths", {}).values():
            for operation in path.values():
                responses = operation.setdefault("responses", {})
                for code in ("422", "default"):
                    responses.setdefault(code, {"description": "a problem"})
                for code, response in responses.items():
                    if code == "default" or int(code) >= 400:
                        response["content"] = {"application/problem+json": {"schema": _PROBLEM_REF}}
        # OGC's oas30 conformance class: the document is served as OpenAPI 3.0
        app.openapi_schema = to_openapi30(schema)
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
