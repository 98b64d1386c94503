"""The landing page, conformance, and the operational probes (health, readiness, metrics)."""

from __future__ import annotations

import asyncio
from typing import Any

from fastapi import APIRouter, Request, Response
from prometheus_client import CONTENT_TYPE_LATEST, generate_latest

from ..deps import MetricsDep, SettingsDep, require_api_key
from ..problems import Problem
from ..schemas import Conformance, LandingPage
from ..views import REL_PROCESS, base_url, link
from .viewer import page, prefers_html

router = APIRouter(tags=["Capabilities"])

_CONF = "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/"
#: OGC API - Processes, Part 1 conformance classes this service implements.
CONFORMANCE = [
    _CONF + "core",
    _CONF + "ogc-process-description",
    _CONF + "json",
    _CONF + "oas30",
    _CONF + "job-list",
    _CONF + "dismiss",
]


@router.get(
    "/",
    response_model=LandingPage,
    summary="Landing page (the web viewer for clients that ask for HTML)",
    responses={200: {"content": {"text/html": {"schema": {"type": "string"}}}}},
)
def landing(request: Request, response: Response) -> Any:
    if prefers_html(request.headers.get("accept", "")):
        return page()
    response.headers["Vary"] = "Accept"  # the same URL answers HTML to browsers
    base = base_url(request)
    return {
        "title": "evomesh",
        "description": (
            "Unstructured triangular meshing of planar regions with genetic-algorithm smoothing "
            "(OGC API - Processes)."
        ),
        "links": [
            link(f"{base}/", "self", title="this document"),
            link(
                f"{base}/openapi.json",
                "service-desc",
                "application/vnd.oai.openapi+json;version=3.0",
                "the API definition",
            ),
            link(f"{base}/docs", "service-doc", "text/html", "the API documentation"),
            link(f"{base}/viewer", "alternate", "text/html", "the web viewer"),
            link(
                f"{base}/conformance",
                "http://www.opengis.net/def/rel/ogc/1.0/conformance",
                title="conformance classes",
            ),
            link(f"{base}/processes", REL_PROCESS, title="processes"),
            link(f"{base}/jobs", "http://www.opengis.net/def/rel/ogc/1.0/job-list", title="jobs"),
        ],
    }


@router.get("/conformance", response_model=Conformance, summary="Conformance classes")
def conformance() -> dict[str, Any]:
    return {"conformsTo": CONFORMANCE}


@router.get("/health", tags=["Operations"], summary="Liveness")
def health() -> dict[str, str]:
    return {"status": "ok"}


@router.get("/ready", tags=["Operations"], summary="Readiness: store writable, workers alive")
async def ready(request: Request) -> dict[str, Any]:
    manager = getattr(request.app.state, "manager", None)
    if manager is None:
        raise Problem(503, "the service is not running", headers={"Retry-After": "5"})
    try:
        await asyncio.to_thread(manager.store.ping)
    except Exception as exc:
        raise Problem(503, f"the job store cannot be written: {exc}") from exc
    if not manager.backend.alive():
        raise Problem(503, "no worker is alive", headers={"Retry-After": "5"})
    stats = manager.backend.stats()
    # A backend may need fewer warm workers than it has (a shared Dask cluster: one).
    needed = getattr(manager.backend, "ready_needed", lambda s: s.workers)(stats)
    if 0 <= stats.ready < max(needed, 1):
        # A job handed to a cold worker would wait for its kernels to compile.
        raise Problem(
            503,
            f"{stats.ready} of {stats.workers} workers have warmed up (waiting for {needed})",
            headers={"Retry-After": "5"},
        )
    return {
        "status": "ready",
        "backend": manager.backend.name,
        "workers": {
            "configured": stats.workers,
            "alive": stats.alive,
            "busy": stats.busy,
            "warm": stats.ready,  # -1: the backend does not know
        },
        "queued": stats.queued,
    }


@router.get(
    "/metrics",
    tags=["Operations"],
    summary="Prometheus metrics",
    response_class=Response,
    responses={200: {"content": {"text/plain": {"schema": {"type": "string"}}}}},
)
async def metrics(request: Request, metrics: MetricsDep, settings: SettingsDep) -> Response:
    if settings.metrics_require_key:
        await require_api_key(request, settings)
    return Response(generate_latest(metrics.registry), media_type=CONTENT_TYPE_LATEST)
