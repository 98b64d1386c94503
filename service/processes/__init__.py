"""The processes the service offers (``mesh``, ``smooth``, ``quality``) as a registry.

Each process is a module: its inputs model (whose JSON schema becomes the OGC process
description), ``prepare`` (run at submission: validate, check the limits, resolve the defaults
and the seed into a typed request, whose JSON the job stores) and ``execute`` (the typed
request through the engine into the result document, in a worker or in the command line).
This package is the only place a request meets the engine; errors found while preparing are
reported before any job exists, as 422 problems pointing at the offending input.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..jobs.task import ProgressCallback
from . import mesh, quality, smooth
from .base import Prepared, Process, Runner, Where, count_rings, inputs_at, triangle_cap
from .mesh import estimate_mesh

__all__ = [
    "PROCESSES",
    "Prepared",
    "Process",
    "Where",
    "count_rings",
    "estimate_mesh",
    "inputs_at",
    "run",
    "triangle_cap",
]

#: The processes by id.
PROCESSES: dict[str, Process] = {p.id: p for p in (mesh.PROCESS, smooth.PROCESS, quality.PROCESS)}

_RUNNERS: dict[str, Runner] = {"mesh": mesh.run, "smooth": smooth.run, "quality": quality.run}


def run(
    process_name: str,
    payload: dict[str, Any],
    progress: ProgressCallback,
    should_stop: Callable[[], bool],
) -> tuple[bytes, Any]:
    """The worker entry point: the stored ``payload`` of a ``process_name`` job rebuilt as its
    typed request and run; ``(compressed document, figures)``."""
    return _RUNNERS[process_name](payload, progress, should_stop)
