"""Request models shared by the processes: the smoothing input, a mesh document input, a
refinement, and the OGC execute request around a process's inputs (whose own models live in
:mod:`service.processes`).

The OGC process descriptions are generated from these models, so the documentation cannot drift
from validation. Defaults come from the engine's parameter dataclasses; the smoothing methods and
fitness functions are checked against the engine's registries when a request arrives, so a method
added to ``engine.SMOOTHERS`` becomes valid without a change here.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

import engine
from engine import SmoothingParams
from engine.params import SELECTIONS

__all__ = [
    "BOUNDARY_SCHEMA",
    "MAX_REFINEMENTS",
    "SMOOTHING_DEFAULTS",
    "STRICT",
    "ExecuteRequest",
    "Fitness",
    "MeshDocumentInput",
    "RefinementInput",
    "SmoothingInput",
    "Subscriber",
]

#: The engine's smoothing defaults (the inputs' defaults).
SMOOTHING_DEFAULTS = SmoothingParams()
#: Unknown members are errors, and numbers are numbers: "0.1" or true is not a size.
STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)

_POSITION = {"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 3}
_RING = {"type": "array", "items": _POSITION, "minItems": 3}
_POLYGON = {"type": "array", "items": _RING, "minItems": 1}
_GEOMETRY = {
    "anyOf": [
        {
            "type": "object",
            "required": ["type", "coordinates"],
            "properties": {"type": {"const": "Polygon"}, "coordinates": _POLYGON},
        },
        {
            "type": "object",
            "required": ["type", "coordinates"],
            "properties": {
                "type": {"const": "MultiPolygon"},
                "coordinates": {"type": "array", "items": _POLYGON, "minItems": 1},
            },
        },
    ]
}
_FEATURE = {
    "type": "object",
    "required": ["type", "geometry"],
    "properties": {
        "type": {"const": "Feature"},
        "geometry": _GEOMETRY,
        "properties": {"type": ["object", "null"]},
    },
}
#: What ``boundary`` accepts (checked by :func:`service.geojson.parse_region`).
BOUNDARY_SCHEMA: dict[str, Any] = {
    "description": (
        "The region: a GeoJSON Polygon, MultiPolygon, Feature or FeatureCollection (all its "
        'polygons form one multi-part region), or {"outer": ring, "holes": [ring, ...]}. '
        "Rings are lists of [x, y] positions, open or closed, either winding."
    ),
    "anyOf": [
        *_GEOMETRY["anyOf"],
        _FEATURE,
        {
            "type": "object",
            "required": ["type", "features"],
            "properties": {
                "type": {"const": "FeatureCollection"},
                "features": {"type": "array", "items": _FEATURE, "minItems": 1},
            },
        },
        {
            "type": "object",
            "required": ["outer"],
            "properties": {"outer": _RING, "holes": {"type": "array", "items": _RING}},
        },
    ],
}


def _choices(registry: dict[str, Any]) -> Any:
    """A schema hook listing a registry's names when the schema is generated."""

    def extra(schema: dict[str, Any]) -> None:
        schema["enum"] = sorted(registry)

    return extra


def _known(registry: dict[str, Any], what: str) -> Any:
    def check(value: str) -> str:
        if value not in registry:
            raise ValueError(f"unknown {what} {value!r}; choose one of {sorted(registry)}")
        return value

    return check


Method = Annotated[
    str,
    AfterValidator(_known(engine.SMOOTHERS, "smoothing method")),
    Field(description="smoother: a name of engine.SMOOTHERS"),
    Field(json_schema_extra=_choices(engine.SMOOTHERS)),
]
Fitness = Annotated[
    str,
    AfterValidator(_known(engine.FITNESS, "fitness function")),
    Field(description="node fitness function", json_schema_extra=_choices(engine.FITNESS)),
]


class SmoothingInput(BaseModel):
    """Smoothing parameters (the paper's GA defaults) and the random seed."""

    model_config = STRICT

    # validate_default: the default method may not be installed; refused here, in one place
    method: Method = Field(SMOOTHING_DEFAULTS.method, validate_default=True)
    fitness: Fitness = SMOOTHING_DEFAULTS.fitness
    alpha: float = Field(
        SMOOTHING_DEFAULTS.alpha, ge=0, le=1, description="weight of the angle term"
    )
    beta: float = Field(
        SMOOTHING_DEFAULTS.beta, ge=0, le=1, description="weight of the aspect-ratio term"
    )
    population: int = Field(
        SMOOTHING_DEFAULTS.population, ge=2, le=10_000, description="candidates per node"
    )
    generations: int = Field(
        SMOOTHING_DEFAULTS.generations, ge=1, le=10_000, description="generations per node"
    )
    crossover_rate: float = Field(SMOOTHING_DEFAULTS.crossover_rate, ge=0, le=1)
    mutation_rate: float = Field(SMOOTHING_DEFAULTS.mutation_rate, ge=0, le=1)
    patience: int | None = Field(
        SMOOTHING_DEFAULTS.patience,
        ge=1,
        le=10_000,
        description="stop a node's GA after this many generations without gain (null: never)",
    )
    tolerance: float = Field(
        SMOOTHING_DEFAULTS.tolerance, ge=0, description="stop when a sweep changes less"
    )
    max_sweeps: int = Field(
        SMOOTHING_DEFAULTS.max_sweeps, ge=1, le=10_000, description="most GA sweeps"
    )
    iterations: int = Field(
        SMOOTHING_DEFAULTS.iterations, ge=1, le=10_000, description="Laplacian sweeps"
    )
    threshold: float | None = Field(
        SMOOTHING_DEFAULTS.threshold,
        ge=0,
        le=1,
        description="evolve only nodes with fitness below this",
    )
    selection: Literal[SELECTIONS] = Field(  # type: ignore[valid-type]
        SMOOTHING_DEFAULTS.selection,
        description="which nodes the GA evolves: poor (of poorly shaped triangles) or all",
    )
    poor_quality: float = Field(
        SMOOTHING_DEFAULTS.poor_quality,
        ge=0,
        le=1,
        description="shape quality below which a triangle is poor",
    )
    seed: int | None = Field(
        None,
        ge=0,
        le=2**63 - 1,
        description="random seed; when absent the service chooses one and stores it with the job",
    )


#: The most refinements a ``mesh`` request may list.
MAX_REFINEMENTS = 1000


class RefinementInput(BaseModel):
    """A local size: ``size`` on and near ``geometry``, growing away at ``growth``."""

    model_config = STRICT

    geometry: dict[str, Any] = Field(
        description="a GeoJSON Point, LineString, Polygon, their Multi* forms or a collection"
    )
    size: float = Field(gt=0, description="the edge length asked for on the geometry")
    growth: float | None = Field(
        None,
        gt=1,
        le=100,
        description="largest neighbour size ratio away from the geometry; default the job's",
    )


Index = Annotated[int, Field(ge=0, le=2**31 - 1)]


class ProjectedPoints(BaseModel):
    """A result document's mesh-plane coordinates (metres, when its points are lon/lat)."""

    model_config = ConfigDict(extra="ignore", allow_inf_nan=False, strict=True)

    points: list[Annotated[list[float], Field(min_length=2, max_length=2)]] = Field(min_length=3)


class MeshDocumentInput(BaseModel):
    """A mesh: ``points`` and counter-clockwise, 0-based ``triangles`` (a mesh document)."""

    # A whole result document may be given: its other members are dropped, never kept.
    model_config = ConfigDict(extra="ignore", allow_inf_nan=False, strict=True)

    points: list[Annotated[list[float], Field(min_length=2, max_length=2)]] = Field(min_length=3)
    triangles: list[Annotated[list[Index], Field(min_length=3, max_length=3)]] = Field(min_length=1)
    points_local: list[Annotated[list[float], Field(min_length=2, max_length=2)]] | None = None
    projected: ProjectedPoints | None = None


def _callback_uri(value: str) -> str:
    # Only the scheme is checked here; which hosts are allowed is the service's setting.
    scheme, sep, rest = value.partition("://")
    if scheme.lower() not in ("http", "https") or not sep or not rest.split("/", 1)[0]:
        raise ValueError("a callback URI is an absolute http:// or https:// URL")
    return value


CallbackUri = Annotated[str, Field(max_length=2048), AfterValidator(_callback_uri)]


class Subscriber(BaseModel):
    """OGC's subscriber: URIs the service POSTs the job's status document to when it starts
    (``inProgressUri``), succeeds (``successUri``) or fails (``failedUri``)."""

    model_config = ConfigDict(extra="forbid", strict=True)

    successUri: CallbackUri | None = None  # noqa: N815
    inProgressUri: CallbackUri | None = None  # noqa: N815
    failedUri: CallbackUri | None = None  # noqa: N815


class ExecuteRequest(BaseModel):
    """The OGC execute request. ``outputs`` names the outputs (and the format of a raw one),
    ``response`` the shape of a synchronous answer (``Prefer: wait=N``), ``subscriber`` the
    callbacks; the results stay at ``GET /jobs/{jobID}/results``."""

    model_config = ConfigDict(extra="forbid", strict=True)

    inputs: BaseModel
    outputs: dict[str, Any] | None = None
    response: Literal["document", "raw"] | None = None
    subscriber: Subscriber | None = None
