"""``evomesh serve``: run the HTTP service with uvicorn."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..jobs.factory import BACKENDS


def register(sub: Any) -> None:
    p: argparse.ArgumentParser = sub.add_parser(
        "serve",
        help="run the HTTP service",
        description="Run the OGC API - Processes service. Every EVOMESH_* variable applies; "
        "the flags override them.",
    )
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=8000, help="port (default 8000)")
    p.add_argument("--data-dir", type=Path, default=None, help="job store folder")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: CPUs)")
    p.add_argument(
        "--backend",
        choices=sorted(BACKENDS),
        default=None,
        help="compute backend: a local process pool (default), a Dask cluster, or inline (one "
        "job at a time on a thread of the service: tests and tiny deployments)",
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="tcp://HOST:8786",
        help="Dask scheduler address (backend dask; none: a Dask cluster of --workers processes "
        "on 127.0.0.1)",
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    import uvicorn

    from ..app import create_app
    from ..logs import logging_config
    from ..settings import Settings

    overrides = {
        key: value
        for key, value in {
            "data_dir": args.data_dir,
            "workers": args.workers,
            "backend": args.backend,
            "scheduler": args.scheduler,
        }.items()
        if value is not None
    }
    settings = Settings(**overrides)
    app = create_app(settings)
    uvicorn.run(
        app,
        host=args.host,
        port=args.port,
        log_config=logging_config(settings.log_level),
        # Jobs in flight are re-queued at the next start; do not wait long for open connections.
        timeout_graceful_shutdown=5,
    )
    return 0
