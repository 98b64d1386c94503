"""What every process shares: the :class:`Process` record, where inputs are in a request,
the limits checked at admission, the smoothing input resolved once, and the worker's wrapper
around a process's engine call.

A process module (:mod:`.mesh`, :mod:`.smooth`, :mod:`.quality`) holds its inputs model, a
``prepare`` step (validate, check the limits, resolve every default and the seed into a typed
request) and an ``execute`` step (the typed request through the engine into a result document).
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Protocol, Self

from pydantic import BaseModel

import engine
from engine import EngineError, SmoothingParams
from engine.pipeline import STAGE_WEIGHTS, job_progress

from ..document import mesh_from_document
from ..inputs import ExecuteRequest, MeshDocumentInput, SmoothingInput
from ..jobs.task import ProgressCallback, TaskError, encode_inputs, pack
from ..refusal import InputRefused
from ..settings import Settings

__all__ = [
    "MESH_OUTPUT",
    "Prepared",
    "Process",
    "Request",
    "Where",
    "admitted",
    "check_ga_work",
    "check_limit",
    "check_mesh",
    "count_rings",
    "inputs_at",
    "mesh_only",
    "prepare_stored",
    "run_task",
    "smoothing_from_json",
    "smoothing_json",
    "smoothing_params",
    "stage_progress",
    "triangle_cap",
    "with_seed",
]

#: ``where(input_name) -> JSON pointer`` of an input in the request (for error reports).
Where = Callable[[str], str]


def inputs_at(base: str) -> Where:
    """Inputs found under ``base`` (``/inputs`` in an execute request).

    >>> inputs_at("/inputs")("size")
    '/inputs/size'
    """
    return lambda name: f"{base}/{name}"


class Request(Protocol):
    """A process's typed request: what the job stores (as JSON) and the worker runs."""

    @property
    def seed(self) -> int | None: ...

    def to_json(self) -> dict[str, Any]: ...

    @classmethod
    def from_json(cls, payload: Mapping[str, Any]) -> Self: ...


@dataclass(frozen=True)
class Prepared:
    """A validated request, ready to store and run."""

    #: the typed request as JSON (defaults and seed filled in), or its stored form
    #: (:func:`prepare_stored`)
    inputs: dict[str, Any] | bytes
    seed: int | None
    triangles: int  #: estimated size of the result


def admitted(request: Request, triangles: int) -> Prepared:
    """A prepared request as the job store keeps it."""
    return Prepared(request.to_json(), request.seed, triangles)


def prepare_stored(
    prepare: Callable[[Any, Settings, Where], Prepared],
    inputs: Any,
    settings: Settings,
    where: Where,
) -> Prepared:
    """``prepare(inputs, settings, where)`` with the inputs in the form the store keeps and a
    worker decodes (bytes): run where the request is prepared (a body pool process, a thread),
    so the event loop neither encodes them nor unpickles them as a tree of objects."""
    prepared = prepare(inputs, settings, where)
    return replace(prepared, inputs=encode_inputs(prepared.inputs))


@dataclass(frozen=True)
class Process:
    """One process of the OGC API."""

    id: str
    title: str
    description: str
    inputs_model: type[BaseModel]
    execute_model: type[ExecuteRequest]
    runner: str  #: ``module:function`` run by a worker
    prepare: Callable[[Any, Settings, Where], Prepared]  #: validate, check limits, fill seed
    version: str = "1.0.0"
    keywords: tuple[str, ...] = ()
    outputs: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "title": self.title,
            "description": self.description,
            "version": self.version,
            "keywords": list(self.keywords),
            "jobControlOptions": ["async-execute", "dismiss"],
            "outputTransmission": ["value"],
        }


def count_rings(obj: Any, limit: int = 10**9) -> tuple[int, int]:
    """(rings, positions) in a boundary input, counted without parsing it.

    A ring is a list whose items are lists of numbers; the walk stops early past ``limit``.

    >>> count_rings({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 1]]]})
    (1, 3)
    """
    rings = positions = 0
    stack = [obj]
    while stack and positions <= limit:
        item = stack.pop()
        if isinstance(item, dict):
            stack.extend(item.values())
        elif isinstance(item, list) and item:
            first = item[0]
            if (
                isinstance(first, list)
                and first
                and all(isinstance(c, int | float) and not isinstance(c, bool) for c in first)
            ):
                rings += 1
                positions += len(item)
            else:
                stack.extend(item)
    return rings, positions


def check_limit(value: float, limit: float, what: str, pointer: str) -> None:
    """A 422 ``limit-exceeded`` problem at ``pointer`` when ``value`` is over ``limit``."""
    if value > limit:
        raise InputRefused(
            f"{what} is {value:.4g}, over the limit of {limit:.4g}",
            kind="limit-exceeded",
            title="Input over a limit",
            pointer=pointer,
        )


def check_mesh(mesh: MeshDocumentInput, settings: Settings, where: Where) -> int:
    """Check a mesh input's size, then the mesh itself (so a bad mesh is refused up front);
    its triangle count."""
    at = where("mesh")
    limit = settings.max_triangles
    check_limit(len(mesh.triangles), limit, "the number of triangles", f"{at}/triangles")
    check_limit(len(mesh.points), limit, "the number of points", f"{at}/points")
    try:
        mesh_from_document(mesh.model_dump(exclude_none=True))
    except engine.InvalidMesh as exc:
        pointer = at
        if exc.triangle is not None:
            pointer += f"/triangles/{exc.triangle}"
        elif exc.point is not None:
            pointer += f"/{_points_at(mesh)}/{exc.point}"
        raise InputRefused(exc.message, kind="invalid-mesh", pointer=pointer) from None
    except (TypeError, ValueError, ArithmeticError) as exc:
        raise InputRefused(
            f"the mesh could not be read: {exc}", kind="invalid-mesh", pointer=at
        ) from exc
    return len(mesh.triangles)


def _points_at(mesh: MeshDocumentInput) -> str:
    """Where the points a job uses are (the mesh plane's when the document has them)."""
    if mesh.projected is not None:
        return "projected/points"
    return "points_local" if mesh.points_local else "points"


def mesh_only(mesh: MeshDocumentInput) -> dict[str, Any]:
    """The parts of a mesh document a job uses (a whole result document may be given)."""
    return mesh.model_dump(
        include={"points", "triangles", "points_local", "projected"}, exclude_none=True
    )


def smoothing_params(smoothing: SmoothingInput, where: Where) -> tuple[SmoothingParams, int]:
    """The one step from a smoothing input to the engine's parameters and the seed (chosen now
    when absent, and stored with the job so reruns are identical). The engine's own checks run
    here, so what a worker would refuse is refused at admission (e.g. alpha = beta = 0); the
    method and fitness names were checked by the model."""
    values = smoothing.model_dump()
    seed = values.pop("seed")
    try:
        params = SmoothingParams(**values)
    except ValueError as exc:
        raise InputRefused(str(exc), kind="invalid-input", pointer=where("smoothing")) from None
    return params, secrets.randbits(63) if seed is None else seed


def smoothing_json(params: SmoothingParams, seed: int) -> dict[str, Any]:
    """A job's stored ``smoothing``: the engine's parameters and the seed."""
    return {**asdict(params), "seed": seed}


def smoothing_from_json(stored: Mapping[str, Any]) -> tuple[SmoothingParams, int]:
    """The inverse of :func:`smoothing_json` (a job stored without a seed ran with 0)."""
    values = dict(stored)
    seed = int(values.pop("seed", 0) or 0)
    return SmoothingParams(**values), seed


def ga_factor(smoothing: SmoothingParams) -> int:
    """GA fitness evaluations per interior node (0 for the other smoothers)."""
    if smoothing.method != "ga":
        return 0
    return smoothing.population * smoothing.generations * smoothing.max_sweeps


def check_ga_work(
    smoothing: SmoothingParams, triangles: int, settings: Settings, where: Where
) -> None:
    """Refuse a GA whose work (a node per two triangles) is over the settings' limit."""
    factor = ga_factor(smoothing)
    if not factor:
        return
    nodes = max(1, triangles // 2)
    check_limit(
        float(nodes * factor),
        settings.ga_work_limit,
        "the GA work (nodes x population x generations x sweeps; its limit is max_ga_work, and"
        " no more than job_timeout x ga_rate)",
        where("smoothing"),
    )


def triangle_cap(smoothing: SmoothingParams, settings: Settings) -> int:
    """The most triangles the real mesh of a ``mesh`` job may have: ``max_triangles``, and for
    the GA the count whose work reaches the GA-work limit (a node per two triangles).

    >>> s = Settings(max_triangles=1000, max_ga_work=1e6, _env_file=None)
    >>> triangle_cap(SmoothingParams(population=10, generations=10, max_sweeps=10), s)
    1000
    >>> triangle_cap(SmoothingParams(population=100, generations=100, max_sweeps=10), s)
    20
    """
    factor = ga_factor(smoothing)
    if not factor:
        return settings.max_triangles
    return max(1, min(settings.max_triangles, int(2 * settings.ga_work_limit // factor)))


def with_seed(doc: dict[str, Any], seed: int) -> dict[str, Any]:
    """``doc`` with the seed its smoothing ran with (the one place a result gets it)."""
    doc["summary"]["parameters"]["seed"] = seed
    return doc


def run_task(execute: Callable[[], dict[str, Any]]) -> tuple[bytes, dict[str, Any]]:
    """A worker's run of a process: the document compressed, and the figures of the job; the
    engine's refusals (and a payload it cannot read) are the input's fault
    (:class:`TaskError`), a cancellation stays one."""
    started = time.perf_counter()
    try:
        doc = execute()
    except (EngineError, ValueError, KeyError) as exc:
        if isinstance(exc, engine.Cancelled):
            raise
        raise TaskError(str(exc)) from exc
    data = pack(doc)
    figures = {
        "triangles": len(doc["triangles"]),
        "points": len(doc["points"]),
        "seconds": time.perf_counter() - started,
    }
    return data, figures


#: The output every process gives: a mesh document.
MESH_OUTPUT: dict[str, Any] = {
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

#: A worker entry point: ``(payload, progress, should_stop) -> (data, figures)``.
Runner = Callable[[dict[str, Any], ProgressCallback, Callable[[], bool]], tuple[bytes, Any]]


def stage_progress(
    progress: ProgressCallback, smoothing: SmoothingParams, first: str = "boundary"
) -> Callable[[str, float], None]:
    """The engine's stage reports as the job's progress: each stage's share of the bar is its
    measured cost (:func:`engine.pipeline.job_progress`), the message names it in words. A job
    that starts at stage ``first`` (``smooth``: at "swap") has the bar rescaled to start at 0."""
    weights = STAGE_WEIGHTS[smoothing.selection if smoothing.method == "ga" else "poor"]
    stages = list(weights)
    skipped = sum(weights[s] for s in stages[: stages.index(first)]) / sum(weights.values())
    low = int(99 * skipped)

    def report(percent: int, words: str) -> None:
        progress(round(99 * max(percent - low, 0) / (99 - low)), words)

    return job_progress(report if low else progress, smoothing)
