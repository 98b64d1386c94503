"""The ``mesh`` process: a region (GeoJSON or ``{outer, holes}``) -> mesh -> swap -> smooth.

:class:`MeshInputs` is what a client sends (its JSON schema is the OGC description),
:func:`prepare` checks it against the limits and resolves it into a :class:`MeshRequest` (the
rings as floats in the meshing plane and every parameter resolved: never the client's JSON),
and :func:`execute` runs that request through the engine into the mesh document.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any, Literal, Self

import numpy as np
from pydantic import BaseModel, Field

import engine

from ..control import (
    checked_constraints,
    checked_refinements,
    estimate_or_refuse,
    estimate_subdomains,
    job_region,
    refinement_vertices,
    refinements_of,
    run_mesh,
    stored_tagging,
    subdomains_of,
)
from ..document import result_document
from ..geo import GeoError, UnknownCRS
from ..geojson import (
    BoundaryInputError,
    LocatedInvalidBoundary,
    ParsedRegion,
    parse_region,
    region_crs,
)
from ..inputs import (
    BOUNDARY_SCHEMA,
    MAX_REFINEMENTS,
    STRICT,
    ExecuteRequest,
    RefinementInput,
    SmoothingInput,
)
from ..jobs.task import ProgressCallback
from ..refusal import InputRefused
from ..settings import Settings
from .base import (
    MESH_OUTPUT,
    Prepared,
    Process,
    Where,
    admitted,
    check_ga_work,
    check_limit,
    count_rings,
    run_task,
    smoothing_from_json,
    smoothing_json,
    smoothing_params,
    stage_progress,
    triangle_cap,
    with_seed,
)

__all__ = [
    "LENGTH_RANGE",
    "PROCESS",
    "MeshExecute",
    "MeshInputs",
    "MeshRequest",
    "admit",
    "estimate_mesh",
    "execute",
    "prepare",
    "run",
]

_GROWTH = engine.SizingParams(size=1.0).growth


class MeshInputs(BaseModel):
    """Inputs of the ``mesh`` process.

    Every result is tagged: boundary edges by ring (``outer``, ``hole-k``, prefixed with the
    Feature's ``properties.name``) and by the runs its ``properties.tags`` names, triangles by
    region. A FeatureCollection or MultiPolygon whose polygons share edges is meshed as
    subdomains, each at its own ``h``. ``refinements`` and ``constraints`` are documented below.
    """

    model_config = STRICT

    boundary: Any = Field(json_schema_extra=BOUNDARY_SCHEMA)
    crs: str | None = Field(
        None,
        min_length=1,
        max_length=20_000,
        description=(
            "coordinate reference system of the boundary: any CRS pyproj reads (EPSG:4326, "
            "OGC:CRS84, EPSG:32633, a URN, WKT or PROJ string); default: the boundary's legacy "
            "GeoJSON crs member, else planar. Lon/lat is meshed in metres in a local projection "
            "(sizes in metres) and results come back in this CRS"
        ),
    )
    coordinates: Literal["planar", "wgs84"] = Field(
        "planar", description='wgs84: lon/lat (an alias of crs "OGC:CRS84")'
    )
    size: float | None = Field(
        None,
        gt=0,
        description="target edge length (metres for lon/lat); default: the Feature's `h` property",
    )
    growth: float = Field(_GROWTH, gt=1, le=100, description="largest neighbour size ratio")
    size_min: float | None = Field(None, gt=0, description="lower clamp of the local size")
    size_max: float | None = Field(None, gt=0, description="upper clamp of the local size")
    swap: bool = Field(True, description="improve connectivity by diagonal swapping")
    smoothing: SmoothingInput = Field(default_factory=SmoothingInput)
    refinements: list[RefinementInput] = Field(
        default_factory=list,
        max_length=MAX_REFINEMENTS,
        description=(
            "local sizes: the size near each geometry is its `size`, growing away from it at"
            " its own `growth` (default the job's; inside a Polygon: `size`); combined with the"
            " region's sizing and each other by the minimum. Coordinates as the boundary's"
            " (metres for lon/lat); their vertices count against the boundary-vertex limit"
        ),
    )
    constraints: Any = Field(
        None,
        description=(
            "a GeoJSON geometry or FeatureCollection of (Multi)LineStrings and (Multi)Points"
            " inside the region: lines become chains of mesh edges tagged with their Feature's"
            " `name`, points become mesh nodes; neither moves nor is swapped away. In the"
            " boundary's coordinates (lon/lat for geographic input); with subdomains too"
        ),
    )
    resample: bool = Field(
        False,
        description=(
            "re-discretise the rings to the local size instead of keeping every vertex (for"
            " digitised boundaries): corners stay, the meshed boundary stays within"
            " `resample_tolerance` of the input; the result's summary.boundary.max_deviation"
            " reports the largest distance"
        ),
    )
    resample_tolerance: float | None = Field(
        None,
        gt=0,
        description="with `resample`, the largest distance allowed (default 0.1 of the size)",
    )


class MeshExecute(ExecuteRequest):
    inputs: MeshInputs


@dataclass(frozen=True)
class MeshRequest:
    """A ``mesh`` job as stored and run: the normalised input the engine needs."""

    parts: list[Any]  #: the rings as floats in the meshing plane, ``[(outer, holes), ...]``
    crs: dict[str, Any] | None  #: the CRS names that map the result back (``None``: planar)
    sizing: engine.SizingParams  #: resolved sizes, refinements included
    swap: bool
    smoothing: engine.SmoothingParams
    seed: int
    max_triangles: int  #: the limit on the real mesh (the service's, not the engine's default)
    tagging: dict[str, Any] | None  #: the named runs (:func:`service.control.stored_tagging`)
    refinements: list[dict[str, Any]]  #: as stored (:func:`service.control.checked_refinements`)
    constraints: dict[str, Any] | None  #: as stored (:func:`service.control.checked_constraints`)
    subdomains: dict[str, Any] | None  #: ``{"sizes": [...]}`` for polygons sharing edges
    coordinates: str | None = None  #: ``"wgs84"``: lon/lat rings of a job stored before ``crs``

    def to_json(self) -> dict[str, Any]:
        """What the job stores (the keys jobs have always had)."""
        s = self.sizing
        out: dict[str, Any] = {
            "parts": self.parts,
            "crs": self.crs,
            "size": s.size,
            "growth": s.growth,
            "size_min": s.size_min,
            "size_max": s.size_max,
            "resample": s.resample,
            "resample_tolerance": s.resample_tolerance,
            "swap": self.swap,
            "smoothing": smoothing_json(self.smoothing, self.seed),
            "max_triangles": self.max_triangles,
            "tagging": self.tagging,
            "refinements": self.refinements,
            "constraints": self.constraints,
            "subdomains": self.subdomains,
        }
        if self.coordinates is not None:
            out["coordinates"] = self.coordinates
        return out

    @classmethod
    def from_json(cls, payload: Mapping[str, Any]) -> Self:
        """The request a job stored (those stored before a member existed get its default)."""
        smoothing, seed = smoothing_from_json(payload["smoothing"])
        refinements = list(payload.get("refinements") or [])
        sizing = engine.SizingParams(
            float(payload["size"]),
            float(payload["growth"]),
            payload.get("size_min"),
            payload.get("size_max"),
            refinements_of(refinements),
            resample=bool(payload.get("resample", False)),
            resample_tolerance=payload.get("resample_tolerance"),
        )
        return cls(
            parts=[(outer, holes) for outer, holes in payload["parts"]],
            crs=payload.get("crs"),
            sizing=sizing,
            swap=bool(payload["swap"]),
            smoothing=smoothing,
            seed=seed,
            max_triangles=int(payload["max_triangles"]),
            tagging=payload.get("tagging"),
            refinements=refinements,
            constraints=payload.get("constraints"),
            subdomains=payload.get("subdomains"),
            coordinates=payload.get("coordinates"),
        )


def estimate_mesh(
    region: engine.Region, sizing: engine.SizingParams, cap: int | None = None
) -> int:
    """Triangles the engine expects for ``region`` at ``sizing``: the engine's own estimator
    (the one the worker checks again), so admission and the engine cannot disagree; counting
    stops past ``cap`` (then the result only says the count is over it).

    >>> square = engine.make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> estimate_mesh(square, engine.SizingParams(size=0.1))
    249
    """
    from engine.sizing import build_size_field

    return int(engine.estimate_triangles(region, build_size_field(region, sizing), cap=cap))


#: Lengths are accepted between these multiples of the region's extent: below, the squares the
#: estimator takes underflow; above, the length means nothing (a triangle per corner already).
LENGTH_RANGE = (1e-9, 1e3)


def _sizing(inputs: MeshInputs, parsed: ParsedRegion, where: Where) -> engine.SizingParams:
    """The one step from the size inputs (or the Feature's ``h``) to the engine's sizing."""
    size = inputs.size
    if size is None:
        h = parsed.properties.get("h")
        if not isinstance(h, int | float) or isinstance(h, bool) or not (0 < h < math.inf):
            raise InputRefused(
                "size is required (or a positive 'h' property on the Feature)",
                kind="invalid-input",
                pointer=where("size"),
            )
        size = float(h)
    x0, y0, x1, y1 = parsed.region.bounds
    extent = max(x1 - x0, y1 - y0)
    lo, hi = extent * LENGTH_RANGE[0], extent * LENGTH_RANGE[1]
    lengths = {"size": size, "size_min": inputs.size_min, "size_max": inputs.size_max}
    for name, value in lengths.items():
        if value is not None and not lo <= value <= hi:
            raise InputRefused(
                f"{name} is {value:.4g}; for this region (extent {extent:.4g}) it must be"
                f" between {lo:.4g} and {hi:.4g}",
                kind="invalid-input",
                pointer=where(name),
            )
    try:
        return engine.SizingParams(
            size,
            inputs.growth,
            inputs.size_min,
            inputs.size_max,
            resample=inputs.resample,
            resample_tolerance=inputs.resample_tolerance,
        )
    except ValueError as exc:
        raise InputRefused(str(exc), kind="invalid-input", pointer=where("size")) from None


def _parse(inputs: MeshInputs, where: Where, densify: float | None = None) -> ParsedRegion:
    """The region in its meshing plane; the geodata layer's errors as 422s pointing at the input
    they come from (an unknown CRS at ``crs``, or at the boundary's legacy ``crs`` member)."""
    at = where("boundary")
    crs_at = where("crs") if inputs.crs is not None else f"{at}/crs"
    try:
        crs = region_crs(inputs.boundary, inputs.crs, inputs.coordinates)
        return parse_region(inputs.boundary, pointer=at, crs=crs, densify=densify)
    except (BoundaryInputError, engine.InvalidBoundary):
        raise
    except UnknownCRS as exc:
        raise InputRefused(exc.message, kind="invalid-input", pointer=crs_at) from None
    except GeoError as exc:  # RegionTooLarge and the like: the region as a whole
        raise InputRefused(exc.message, kind="invalid-boundary", pointer=at) from None
    except (TypeError, ValueError, ArithmeticError, RuntimeWarning) as exc:
        # Input the parser did not foresee (numbers near the float limit overflow, a warning
        # when warnings are errors): still the input's fault, never a server error.
        raise InputRefused(
            f"the boundary could not be read: {exc}", kind="invalid-boundary", pointer=at
        ) from exc


def _region(inputs: MeshInputs, where: Where) -> tuple[ParsedRegion, list[float | None] | None]:
    """The parsed region, and each polygon's own size when its polygons are subdomains."""
    try:
        return _parse(inputs, where), None
    except LocatedInvalidBoundary as exc:  # polygons sharing edges are subdomains
        crs = region_crs(inputs.boundary, inputs.crs, inputs.coordinates)
        return subdomains_of(inputs.boundary, where("boundary"), crs, exc)


def prepare(inputs: MeshInputs, settings: Settings, where: Where) -> tuple[MeshRequest, int]:
    """Validate ``inputs`` against the limits of ``settings``: the request and its estimated
    triangle count, or an :class:`~service.refusal.InputRefused` (or a boundary error) located
    with ``where``."""
    rings, vertices = count_rings(inputs.boundary, settings.max_vertices)
    at = where("boundary")
    check_limit(rings, settings.max_rings, "the number of rings", at)
    check_limit(vertices, settings.max_vertices, "the number of boundary vertices", at)
    parsed, sizes = _region(inputs, where)
    # Refinements, constraints and named runs are given in the input CRS and meshed as the
    # region is (lon/lat: projected, sizes in metres).
    geographic = parsed.projection is not None and parsed.projection.geographic
    sizing = _sizing(inputs, parsed, where)
    # Lon/lat lines are straight in lon/lat (RFC 7946): split at the size to follow them.
    densify = sizing.size if geographic else None
    refinements = checked_refinements(
        inputs.refinements,
        parsed.projection,
        parsed.region.n_vertices,
        settings.max_vertices,
        where("refinements"),
        densify,
    )
    sizing = replace(sizing, refinements=refinements_of(refinements))
    smoothing, seed = smoothing_params(inputs.smoothing, where)
    if sizes is None:
        triangles = estimate_or_refuse(parsed.region, sizing, settings.max_triangles, where("size"))
    else:
        triangles = estimate_subdomains(
            parsed, sizes, sizing, settings.max_triangles, where("size")
        )
    check_ga_work(smoothing, triangles, settings, where)
    if geographic and sizes is None:
        # Lon/lat edges are straight in lon/lat (RFC 7946): split them at the size so the
        # meshed boundary follows them (sizes were checked first, so this stays small).
        parsed = _parse(inputs, where, densify=sizing.size)
    tagging = stored_tagging(inputs.boundary, parsed, at)  # renumbered as the densified rings
    request = MeshRequest(
        parts=parsed.parts,
        crs=parsed.crs(),
        sizing=sizing,
        swap=inputs.swap,
        smoothing=smoothing,
        seed=seed,
        max_triangles=triangle_cap(smoothing, settings),
        tagging=tagging,
        refinements=refinements,
        constraints=checked_constraints(
            inputs.constraints,
            parsed.region,
            parsed.projection,
            where("constraints"),
            densify,
            parsed.region.n_vertices + refinement_vertices(refinements),
            settings.max_vertices,
        ),
        subdomains=None if sizes is None else {"sizes": sizes},
    )
    return request, triangles


def admit(inputs: MeshInputs, settings: Settings, where: Where) -> Prepared:
    """:func:`prepare` as the job store keeps it."""
    return admitted(*prepare(inputs, settings, where))


def execute(
    request: MeshRequest, progress: engine.ProgressFn, should_stop: engine.StopFn
) -> dict[str, Any]:
    """The mesh document of ``request``; the engine's errors as they come."""
    payload = request.to_json()  # the control layer reads the stored form
    region, crs = job_region(payload)
    params = engine.PipelineParams(
        request.sizing,
        swap=request.swap,
        max_triangles=request.max_triangles,
        smoothing=request.smoothing,
    )
    rng = np.random.default_rng(request.seed)
    result, tags = run_mesh(payload, region, params, rng, progress, should_stop)
    return with_seed(result_document(result, crs, tags=tags), request.seed)


def run(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Callable[[], bool]
) -> tuple[bytes, dict[str, Any]]:
    """The worker's entry point: a stored ``mesh`` job to its compressed document."""

    def job() -> dict[str, Any]:
        request = MeshRequest.from_json(payload)
        return execute(request, stage_progress(progress, request.smoothing), should_stop)

    return run_task(job)


#: The process as the OGC API offers it.
PROCESS = Process(
    id="mesh",
    title="Mesh a region",
    description=(
        "Mesh a planar region with holes by advancing front, swap diagonals, then smooth "
        "interior nodes (genetic algorithm by default). Boundaries and regions are "
        "tagged (properties.name, properties.tags); polygons sharing edges are meshed as "
        "subdomains; refinements and constraints control sizes and keep lines and points."
    ),
    inputs_model=MeshInputs,
    execute_model=MeshExecute,
    runner="service.processes.mesh:run",
    prepare=admit,
    keywords=("mesh", "triangulation", "advancing front", "genetic algorithm"),
    outputs=MESH_OUTPUT,
)
