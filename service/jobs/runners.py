"""What workers run: the processes' computations, from a JSON payload to a compressed document.

These functions run in worker processes (local or remote), never in the service's event loop.
Each takes the job's resolved inputs (the seed included), reports progress as a percentage with
the current stage, and polls ``should_stop`` through the engine.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

import engine
from engine import EngineError, PipelineParams, SizingParams, SmoothingParams

from ..control import job_region, refinements_of, run_mesh
from ..document import cell_data, mesh_from_document, result_document
from .task import ProgressCallback, TaskError, _job_progress, pack, unpack

__all__ = ["mesh", "pack", "quality", "smooth", "unpack"]


def smoothing_params(inputs: dict[str, Any]) -> tuple[SmoothingParams, int]:
    """The engine's smoothing parameters and the seed from a ``smoothing`` input."""
    values = dict(inputs)
    seed = int(values.pop("seed", 0) or 0)
    return SmoothingParams(**values), seed


def _figures(result: engine.Result, started: float) -> dict[str, Any]:
    return {
        "triangles": result.smoothed.mesh.n_triangles,
        "points": result.smoothed.mesh.n_points,
        "seconds": time.perf_counter() - started,
    }


def mesh(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Callable[[], bool]
) -> tuple[bytes, dict[str, Any]]:
    """The ``mesh`` process: boundary -> mesh -> swap -> smooth."""
    started = time.perf_counter()
    try:
        region, crs = job_region(payload)
        smoothing, seed = smoothing_params(payload["smoothing"])
        params = PipelineParams(
            SizingParams(
                float(payload["size"]),
                float(payload["growth"]),
                payload.get("size_min"),
                payload.get("size_max"),
                refinements_of(payload.get("refinements", [])),
                # .get: jobs stored before resampling existed lack the two
                resample=bool(payload.get("resample", False)),
                resample_tolerance=payload.get("resample_tolerance"),
            ),
            swap=bool(payload["swap"]),
            # The service's limits (max_triangles, and the GA work as triangles) on the real
            # mesh, not the engine's own default.
            max_triangles=int(payload["max_triangles"]),
            smoothing=smoothing,
        )
        result, tags = run_mesh(
            payload,
            region,
            params,
            np.random.default_rng(seed),
            _job_progress(progress, smoothing),
            should_stop,
        )
    except (EngineError, ValueError, KeyError) as exc:
        if isinstance(exc, engine.Cancelled):
            raise
        raise TaskError(str(exc)) from exc
    doc = result_document(result, crs, tags=tags)
    doc["summary"]["parameters"]["seed"] = seed
    return pack(doc), _figures(result, started)


def smooth(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Callable[[], bool]
) -> tuple[bytes, dict[str, Any]]:
    """The ``smooth`` process: an existing mesh -> swap -> smooth."""
    started = time.perf_counter()
    try:
        mesh_in = mesh_from_document(payload["mesh"])
        smoothing, seed = smoothing_params(payload["smoothing"])
        result = engine.smooth_mesh(
            mesh_in,
            smoothing,
            swap=bool(payload["swap"]),
            rng=np.random.default_rng(seed),
            progress=_job_progress(progress, smoothing, first="swap"),
            should_stop=should_stop,
        )
    except (EngineError, ValueError) as exc:
        if isinstance(exc, engine.Cancelled):
            raise
        raise TaskError(str(exc)) from exc
    doc = result_document(result)
    doc["summary"]["parameters"]["seed"] = seed
    return pack(doc), _figures(result, started)


def quality(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Callable[[], bool]
) -> tuple[bytes, dict[str, Any]]:
    """The ``quality`` process: per-triangle figures, node fitness and the summary of a mesh."""
    started = time.perf_counter()
    try:
        mesh_in = mesh_from_document(payload["mesh"])
        params = SmoothingParams(
            fitness=payload["fitness"], alpha=payload["alpha"], beta=payload["beta"]
        )
        progress(10, "assessing quality")
        snap = engine.assess_mesh(mesh_in, params)
    except (EngineError, ValueError, KeyError) as exc:
        raise TaskError(str(exc)) from exc
    doc = {
        "points": snap.mesh.points.tolist(),
        "triangles": snap.mesh.triangles.tolist(),
        "point_data": {
            "fitness": snap.fitness.tolist(),
            "boundary": snap.mesh.boundary_nodes.astype(int).tolist(),
        },
        "cell_data": cell_data(snap),
        "summary": {"mesh": snap.summary, "parameters": {"fitness": params.fitness}},
    }
    figures = {
        "triangles": snap.mesh.n_triangles,
        "points": snap.mesh.n_points,
        "seconds": time.perf_counter() - started,
    }
    return pack(doc), figures
