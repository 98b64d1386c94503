"""The ``quality`` process: per-triangle quality, per-node fitness and the summary of a mesh."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Self

from pydantic import BaseModel, Field

import engine
from engine import SmoothingParams

from ..document import cell_data, mesh_from_document
from ..inputs import SMOOTHING_DEFAULTS, STRICT, ExecuteRequest, Fitness, MeshDocumentInput
from ..jobs.task import ProgressCallback
from ..refusal import InputRefused
from ..settings import Settings
from .base import MESH_OUTPUT, Prepared, Process, Where, admitted, check_mesh, mesh_only, run_task

__all__ = [
    "PROCESS",
    "QualityExecute",
    "QualityInputs",
    "QualityRequest",
    "admit",
    "execute",
    "prepare",
    "run",
]


class QualityInputs(BaseModel):
    """Inputs of the ``quality`` process."""

    model_config = STRICT

    mesh: MeshDocumentInput
    fitness: Fitness = SMOOTHING_DEFAULTS.fitness
    alpha: float = Field(SMOOTHING_DEFAULTS.alpha, ge=0, le=1)
    beta: float = Field(SMOOTHING_DEFAULTS.beta, ge=0, le=1)


class QualityExecute(ExecuteRequest):
    inputs: QualityInputs


@dataclass(frozen=True)
class QualityRequest:
    """A ``quality`` job as stored and run."""

    mesh: dict[str, Any]  #: the mesh document's points and triangles (:func:`.base.mesh_only`)
    params: SmoothingParams  #: the fitness function and its weights

    #: A quality job draws no random numbers.
    seed = None

    def to_json(self) -> dict[str, Any]:
        p = self.params
        return {"mesh": self.mesh, "fitness": p.fitness, "alpha": p.alpha, "beta": p.beta}

    @classmethod
    def from_json(cls, payload: Mapping[str, Any]) -> Self:
        params = SmoothingParams(
            fitness=payload["fitness"], alpha=payload["alpha"], beta=payload["beta"]
        )
        return cls(payload["mesh"], params)


def prepare(inputs: QualityInputs, settings: Settings, where: Where) -> tuple[QualityRequest, int]:
    """Validate ``inputs`` against the limits: the request and the mesh's triangle count."""
    try:
        params = SmoothingParams(fitness=inputs.fitness, alpha=inputs.alpha, beta=inputs.beta)
    except ValueError as exc:
        raise InputRefused(str(exc), kind="invalid-input", pointer=where("alpha")) from None
    triangles = check_mesh(inputs.mesh, settings, where)
    return QualityRequest(mesh_only(inputs.mesh), params), triangles


def admit(inputs: QualityInputs, settings: Settings, where: Where) -> Prepared:
    """:func:`prepare` as the job store keeps it."""
    return admitted(*prepare(inputs, settings, where))


def execute(request: QualityRequest) -> dict[str, Any]:
    """The quality document of the request's mesh."""
    snap = engine.assess_mesh(mesh_from_document(request.mesh), request.params)
    return {
        "points": snap.mesh.points.tolist(),
        "triangles": snap.mesh.triangles.tolist(),
        "point_data": {
            "fitness": snap.fitness.tolist(),
            "boundary": snap.mesh.boundary_nodes.astype(int).tolist(),
        },
        "cell_data": cell_data(snap),
        "summary": {"mesh": snap.summary, "parameters": {"fitness": request.params.fitness}},
    }


def run(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Callable[[], bool]
) -> tuple[bytes, dict[str, Any]]:
    """The worker's entry point: a stored ``quality`` job to its compressed document."""

    def job() -> dict[str, Any]:
        request = QualityRequest.from_json(payload)
        progress(10, "assessing quality")
        return execute(request)

    return run_task(job)


#: The process as the OGC API offers it.
PROCESS = Process(
    id="quality",
    title="Assess a mesh",
    description="Per-triangle quality, per-node fitness and summary figures of a mesh.",
    inputs_model=QualityInputs,
    execute_model=QualityExecute,
    runner="service.processes.quality:run",
    prepare=admit,
    keywords=("mesh", "quality"),
    outputs=MESH_OUTPUT,
)
