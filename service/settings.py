"""The one settings class: every knob of the service, read from ``EVOMESH_*`` variables.

Nothing reads the environment at import time; :func:`service.app.create_app` takes a
:class:`Settings` instance, and ``Settings()`` reads the environment when it is constructed.

>>> s = Settings(workers=2, api_keys="a, b", _env_file=None)
>>> s.workers, s.api_keys
(2, ['a', 'b'])
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

__all__ = ["Settings"]


def _cpu_count() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)


class Settings(BaseSettings):
    """Service configuration (environment variables ``EVOMESH_<NAME>``)."""

    model_config = SettingsConfigDict(env_prefix="EVOMESH_", extra="ignore")

    data_dir: Path = Field(Path("evomesh-data"), description="folder of the SQLite job store")
    workers: int = Field(default_factory=_cpu_count, ge=1, le=256, description="worker processes")
    worker_nice: int = Field(
        5,
        ge=0,
        le=19,
        description="how much lower the local workers' CPU priority is than the service's, so"
        " status requests stay fast while every core meshes (0: the same)",
    )
    backend: Literal["local", "dask", "inline"] = Field(
        "local",
        description="compute backend: local worker processes, a Dask cluster, or inline (one"
        " task at a time on a thread of the service: for tests and tiny deployments)",
    )
    scheduler: str | None = Field(
        None, description="Dask scheduler address (backend dask); none: a local Dask cluster"
    )
    scheduler_timeout: float = Field(
        120.0,
        gt=0,
        description="seconds the dask backend waits for a lost scheduler before failing the jobs"
        " waiting for it",
    )
    stop_poll: float = Field(
        0.25, gt=0, description="seconds between a Dask worker's checks for a stop request"
    )

    max_body_bytes: int = Field(32 * 1024 * 1024, ge=1024, description="request body limit")
    max_json_depth: int = Field(
        32,
        ge=8,
        le=512,
        description="nesting depth of a request body's JSON (arrays and objects), checked before"
        " it is decoded",
    )
    max_vertices: int = Field(100_000, ge=3, description="boundary vertices (or mesh points)")
    max_rings: int = Field(1_000, ge=1, description="rings of a boundary, holes included")
    max_triangles: int = Field(2_000_000, ge=1, description="estimated triangles of one job")
    max_ga_work: float = Field(
        2e10, gt=0, description="GA fitness evaluations: nodes x population x generations x sweeps"
    )
    max_batch_items: int = Field(10_000, ge=1, description="jobs of one batch")
    max_queued: int = Field(
        20_000, ge=1, description="jobs waiting to start; beyond it execution answers 429"
    )
    max_queued_per_key: int | None = Field(
        None,
        ge=1,
        description="jobs of one API key waiting to start; beyond it that key gets 429 (none:"
        " only max_queued)",
    )

    ga_rate: float = Field(
        5e6,
        gt=0,
        description="GA fitness evaluations per second of one worker (measured: 2.9e6-4.1e6 on"
        " a loaded 2-core machine); max_ga_work buys at most job_timeout seconds at this rate",
    )
    job_timeout: float = Field(3600.0, gt=0, description="seconds one attempt of a job may run")
    max_attempts: int = Field(3, ge=1, description="starts of a job before it fails for good")
    cancel_grace: float = Field(
        10.0, gt=0, description="seconds a stopping job gets before its worker is killed"
    )
    result_retention: float = Field(
        7 * 24 * 3600.0, gt=0, description="seconds finished jobs and results are kept"
    )
    purge_interval: float = Field(600.0, gt=0, description="seconds between purges")
    reconcile_interval: float = Field(
        5.0,
        gt=0,
        description="seconds between passes of the reconciler, which retries failed store writes"
        " and re-queues or fails jobs they left behind",
    )
    store_retry_after: int = Field(
        10, ge=1, description="Retry-After (seconds) of a 503 for a store that cannot be written"
    )

    api_keys: Annotated[list[str], NoDecode] = Field(
        default_factory=list, description="comma-separated keys; empty: no authentication"
    )
    cors_origins: Annotated[list[str], NoDecode] = Field(
        default_factory=list, description="comma-separated origins allowed by CORS"
    )
    metrics_require_key: bool = Field(
        False, description="with API keys configured, /metrics asks for one too"
    )
    public_url: str | None = Field(
        None,
        pattern=r"^https?://[^/?#]+(/[^?#]*)?$",
        description="the service's public base URL, used in links and Location headers; none:"
        " the request's own, with its Host checked against trusted_hosts",
    )
    trusted_hosts: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="comma-separated Host names the service answers (e.g. 'api.example.org,"
        " *.example.org'); empty: any (set it, or public_url, when the port is public)",
    )
    max_picture_pixels: int = Field(
        4096 * 4096, ge=64 * 64, description="width x height of a rendered PNG/SVG picture"
    )
    render_workers: int = Field(
        2, ge=1, le=64, description="pictures rendered at once (a pool apart from store work)"
    )
    render_cache_bytes: int = Field(
        64 * 1024 * 1024, ge=0, description="memory of the rendered-picture cache (0: no cache)"
    )
    scheduler_tls_ca: Path | None = Field(
        None, description="CA file the Dask scheduler's certificate is checked against (tls://)"
    )
    scheduler_tls_cert: Path | None = Field(
        None, description="client certificate presented to a tls:// Dask scheduler"
    )
    scheduler_tls_key: Path | None = Field(None, description="private key of scheduler_tls_cert")
    log_level: str = Field("info", description="logging level of the service")
    max_sync_wait: float = Field(
        60.0,
        ge=0,
        description="seconds an execute request with 'Prefer: wait=N' may wait for its job's end"
        " before it is answered 201 with the job (0: always asynchronous)",
    )
    callback_attempts: int = Field(
        5, ge=1, le=20, description="tries of one subscriber callback (POST) before it is dropped"
    )
    callback_backoff: float = Field(
        0.5, gt=0, description="seconds before a callback's first retry; doubled for each next"
    )
    callback_timeout: float = Field(
        10.0, gt=0, description="seconds one callback POST may take (connect, send and answer)"
    )
    callback_deadline: float = Field(
        300.0, gt=0, description="seconds all tries of one callback may take together"
    )
    callback_queue: int = Field(
        1000,
        ge=1,
        description="callbacks waiting to be sent (more are dropped and logged), and jobs with"
        " subscribers at once (more are refused 503)",
    )
    callback_senders: int = Field(4, ge=1, le=64, description="callbacks sent at once")
    callback_private_hosts: bool = Field(
        False,
        description="allow callbacks to loopback, private and link-local addresses (tests, or a"
        " receiver on the service's own network)",
    )

    body_workers: int = Field(
        2,
        ge=0,
        le=16,
        description="processes that decode and validate large request bodies, off the API process's"
        " GIL so other requests keep their answers (0: a thread instead)",
    )
    body_pool_bytes: int = Field(
        1024 * 1024,
        ge=0,
        description="bodies of this many bytes or more go to those processes; smaller ones to a"
        " thread (a process hop costs a copy of the body)",
    )

    @field_validator("api_keys", "cors_origins", "trusted_hosts", mode="before")
    @classmethod
    def _split(cls, value: object) -> object:
        # Environment values are comma-separated lists, not JSON.
        if isinstance(value, str):
            return [item.strip() for item in value.split(",") if item.strip()]
        return value

    @property
    def ga_work_limit(self) -> float:
        """The GA work one job may buy: ``max_ga_work``, and never more than ``job_timeout``
        seconds at ``ga_rate``, so admission cannot accept a job sure to run out of time.

        >>> Settings(max_ga_work=1e10, ga_rate=1e6, job_timeout=60, _env_file=None).ga_work_limit
        60000000.0
        """
        return min(self.max_ga_work, self.ga_rate * self.job_timeout)

    @property
    def database(self) -> Path:
        """The SQLite file of the job store."""
        return self.data_dir / "jobs.sqlite3"
