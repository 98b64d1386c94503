"""Typed dependencies: what a route needs, taken from the app that serves it.

They are ``async`` although they never wait: FastAPI runs plain functions in a thread pool, and
a thread hop per dependency per request costs more than everything they do.
"""

from __future__ import annotations

import hashlib
import secrets
from typing import Annotated

from fastapi import Depends, Request

from .jobs.manager import JobManager
from .jobs.store import JobStore
from .metrics import Metrics
from .problems import Problem
from .settings import Settings

__all__ = [
    "ManagerDep",
    "MetricsDep",
    "OwnerDep",
    "SettingsDep",
    "StoreDep",
    "owner_of",
    "require_api_key",
]


async def get_settings(request: Request) -> Settings:
    settings: Settings = request.app.state.settings
    return settings


async def get_manager(request: Request) -> JobManager:
    manager: JobManager | None = getattr(request.app.state, "manager", None)
    if manager is None:  # the lifespan has not started (or has ended)
        raise Problem(503, "the service is not running", headers={"Retry-After": "5"})
    return manager


async def get_store(manager: Annotated[JobManager, Depends(get_manager)]) -> JobStore:
    return manager.store


async def get_metrics(request: Request) -> Metrics:
    metrics: Metrics = request.app.state.metrics
    return metrics


SettingsDep = Annotated[Settings, Depends(get_settings)]
ManagerDep = Annotated[JobManager, Depends(get_manager)]
StoreDep = Annotated[JobStore, Depends(get_store)]
MetricsDep = Annotated[Metrics, Depends(get_metrics)]


def _presented(request: Request) -> str | None:
    key = request.headers.get("x-api-key")
    if key:
        return key
    scheme, _, token = request.headers.get("authorization", "").partition(" ")
    return token.strip() if scheme.lower() == "bearer" and token.strip() else None


async def require_api_key(request: Request, settings: SettingsDep) -> None:
    """With API keys configured: 401 without a key, 403 with a wrong one."""
    if not settings.api_keys:
        return
    key = _presented(request)
    if key is None:
        raise Problem(
            401,
            "an API key is required (X-API-Key header or Authorization: Bearer)",
            headers={"WWW-Authenticate": "Bearer"},
        )
    if not any(secrets.compare_digest(key.encode(), k.encode()) for k in settings.api_keys):
        raise Problem(403, "the API key is not valid")


def owner_of(key: str | None) -> str:
    """Who a request acts for: a digest of its API key ("" without one). Jobs and batches are
    stored with it (never the key itself); another key sees none of them.

    >>> owner_of(None), owner_of("k1") == owner_of("k1"), owner_of("k1") == owner_of("k2")
    ('', True, False)
    """
    return "" if key is None else hashlib.sha256(key.encode()).hexdigest()[:32]


async def get_owner(request: Request, settings: SettingsDep) -> str:
    """The owner of what the request makes or reads (after :func:`require_api_key`)."""
    await require_api_key(request, settings)
    return owner_of(_presented(request)) if settings.api_keys else ""


OwnerDep = Annotated[str, Depends(get_owner)]
