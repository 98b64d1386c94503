"""Backends by name: :func:`make_backend` builds the one the settings name.

Kept apart from :mod:`service.jobs.backends.base` so that the interface imports none of its
implementations (each is imported here, when chosen).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..settings import Settings
from .backends.base import ComputeBackend

__all__ = ["BACKENDS", "make_backend", "scheduler_security"]


def _local(settings: Settings) -> ComputeBackend:
    from .backends.local import LocalBackend

    return LocalBackend(
        workers=settings.workers, cancel_grace=settings.cancel_grace, nice=settings.worker_nice
    )


def _dask(settings: Settings) -> ComputeBackend:
    try:
        from .backends.dask import DaskBackend
    except ImportError as exc:  # the optional extra is missing
        raise ValueError(
            f"the dask backend needs the dask extra (pip install 'evomesh[dask]'): {exc}"
        ) from exc
    return DaskBackend(
        settings.scheduler,
        workers=settings.workers,
        cancel_grace=settings.cancel_grace,
        stop_poll=settings.stop_poll,
        reconnect_timeout=settings.scheduler_timeout,
        security=scheduler_security(settings),
    )


def _inline(settings: Settings) -> ComputeBackend:
    from .backends.inline import InlineBackend

    return InlineBackend(cancel_grace=settings.cancel_grace)


def scheduler_security(settings: Settings) -> Any:
    """The TLS settings of the connection to a ``tls://`` Dask scheduler (None: plain TCP).

    With ``scheduler_tls_ca`` the scheduler's certificate is checked against that CA and
    encryption is required; ``scheduler_tls_cert`` and ``scheduler_tls_key`` are the service's
    client certificate, for schedulers that require one (mutual TLS).
    """
    paths = (settings.scheduler_tls_ca, settings.scheduler_tls_cert, settings.scheduler_tls_key)
    if all(p is None for p in paths):
        return None
    from distributed.security import Security

    ca, cert, key = (None if p is None else str(p) for p in paths)
    return Security(  # type: ignore[no-untyped-call]
        tls_ca_file=ca, tls_client_cert=cert, tls_client_key=key, require_encryption=True
    )


#: Backend factories by name (``Settings.backend``).
BACKENDS: dict[str, Callable[[Settings], ComputeBackend]] = {
    "local": _local,
    "dask": _dask,
    "inline": _inline,
}


def make_backend(settings: Settings) -> ComputeBackend:
    try:
        factory = BACKENDS[settings.backend]
    except KeyError:
        raise ValueError(
            f"backend {settings.backend!r} is not available; choose one of {sorted(BACKENDS)}"
        ) from None
    return factory(settings)
