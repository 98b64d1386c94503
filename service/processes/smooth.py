"""The ``smooth`` process: an existing mesh -> swap -> smooth.

:class:`SmoothInputs` is what a client sends, :func:`prepare` checks the mesh and the limits
and resolves the smoothing into a :class:`SmoothRequest`, :func:`execute` runs it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Self

import numpy as np
from pydantic import BaseModel, Field

import engine

from ..document import mesh_from_document, result_document
from ..inputs import STRICT, ExecuteRequest, MeshDocumentInput, SmoothingInput
from ..jobs.task import ProgressCallback
from ..settings import Settings
from .base import (
    MESH_OUTPUT,
    Prepared,
    Process,
    Where,
    admitted,
    check_ga_work,
    check_mesh,
    mesh_only,
    run_task,
    smoothing_from_json,
    smoothing_json,
    smoothing_params,
    stage_progress,
    with_seed,
)

__all__ = [
    "PROCESS",
    "SmoothExecute",
    "SmoothInputs",
    "SmoothRequest",
    "admit",
    "execute",
    "prepare",
    "run",
]


class SmoothInputs(BaseModel):
    """Inputs of the ``smooth`` process."""

    model_config = STRICT

    mesh: MeshDocumentInput
    swap: bool = Field(True, description="improve connectivity by diagonal swapping first")
    smoothing: SmoothingInput = Field(default_factory=SmoothingInput)


class SmoothExecute(ExecuteRequest):
    inputs: SmoothInputs


@dataclass(frozen=True)
class SmoothRequest:
    """A ``smooth`` job as stored and run."""

    mesh: dict[str, Any]  #: the mesh document's points and triangles (:func:`.base.mesh_only`)
    swap: bool
    smoothing: engine.SmoothingParams
    seed: int

    def to_json(self) -> dict[str, Any]:
        return {
            "mesh": self.mesh,
            "swap": self.swap,
            "smoothing": smoothing_json(self.smoothing, self.seed),
        }

    @classmethod
    def from_json(cls, payload: Mapping[str, Any]) -> Self:
        smoothing, seed = smoothing_from_json(payload["smoothing"])
        return cls(payload["mesh"], bool(payload["swap"]), smoothing, seed)


def prepare(inputs: SmoothInputs, settings: Settings, where: Where) -> tuple[SmoothRequest, int]:
    """Validate ``inputs`` against the limits: the request and the mesh's triangle count."""
    triangles = check_mesh(inputs.mesh, settings, where)
    smoothing, seed = smoothing_params(inputs.smoothing, where)
    check_ga_work(smoothing, triangles, settings, where)
    return SmoothRequest(mesh_only(inputs.mesh), inputs.swap, smoothing, seed), triangles


def admit(inputs: SmoothInputs, settings: Settings, where: Where) -> Prepared:
    """:func:`prepare` as the job store keeps it."""
    return admitted(*prepare(inputs, settings, where))


def execute(
    request: SmoothRequest,
    progress: engine.ProgressFn | None = None,
    should_stop: engine.StopFn | None = None,
) -> dict[str, Any]:
    """The mesh document of the smoothed mesh; the engine's errors as they come."""
    result = engine.smooth_mesh(
        mesh_from_document(request.mesh),
        request.smoothing,
        swap=request.swap,
        rng=np.random.default_rng(request.seed),
        progress=progress,
        should_stop=should_stop,
    )
    return with_seed(result_document(result), request.seed)


def run(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Callable[[], bool]
) -> tuple[bytes, dict[str, Any]]:
    """The worker's entry point: a stored ``smooth`` job to its compressed document."""

    def job() -> dict[str, Any]:
        request = SmoothRequest.from_json(payload)
        report = stage_progress(progress, request.smoothing, first="swap")
        return execute(request, report, should_stop)

    return run_task(job)


#: The process as the OGC API offers it.
PROCESS = Process(
    id="smooth",
    title="Smooth a mesh",
    description="Swap diagonals and move the interior nodes of an existing mesh.",
    inputs_model=SmoothInputs,
    execute_model=SmoothExecute,
    runner="service.processes.smooth:run",
    prepare=admit,
    keywords=("mesh", "smoothing", "genetic algorithm"),
    outputs=MESH_OUTPUT,
)
