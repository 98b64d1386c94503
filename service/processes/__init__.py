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

from ..jobs.backend import ProgressCallback
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

_MESH_OUTPUT = {
    "mesh": {
        "title": "mesh document",
        "description": (
            "points, counter-clockwise 0-based triangles, per-node fitness, per-triangle "
            "quality figures and the summary of every stage; GET /jobs/{jobID}/results?f= "
            "json | geojson | vtu | msh | svg | png"
        ),
        "schema": {
            "type": "object",
            "contentMediaType": "application/json",
            "required": ["points", "triangles", "point_data", "cell_data", "summary"],
        },
    }
}

#: The processes by id.
PROCESSES: dict[str, Process] = {
    p.id: p
    for p in (
        Process(
            id="mesh",
            title="Mesh a region",
            description=(
                "Mesh a planar region with holes by advancing front, swap diagonals, then smooth "
                "interior nodes (genetic algorithm by default). Boundaries and regions are "
                "tagged (properties.name, properties.tags); polygons sharing edges are meshed as "
                "subdomains; refinements and constraints control sizes and keep lines and points."
            ),
            inputs_model=mesh.MeshInputs,
            execute_model=mesh.MeshExecute,
            runner="service.processes.mesh:run",
            prepare=mesh.admit,
            keywords=("mesh", "triangulation", "advancing front", "genetic algorithm"),
            outputs=_MESH_OUTPUT,
        ),
        Process(
            id="smooth",
            title="Smooth a mesh",
            description="Swap diagonals and move the interior nodes of an existing mesh.",
            inputs_model=smooth.SmoothInputs,
            execute_model=smooth.SmoothExecute,
            runner="service.processes.smooth:run",
            prepare=smooth.admit,
            keywords=("mesh", "smoothing", "genetic algorithm"),
            outputs=_MESH_OUTPUT,
        ),
        Process(
            id="quality",
            title="Assess a mesh",
            description="Per-triangle quality, per-node fitness and summary figures of a mesh.",
            inputs_model=quality.QualityInputs,
            execute_model=quality.QualityExecute,
            runner="service.processes.quality:run",
            prepare=quality.admit,
            keywords=("mesh", "quality"),
            outputs=_MESH_OUTPUT,
        ),
    )
}

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
