"""The processes the service offers (``mesh``, ``smooth``, ``quality``) as a registry.

A :class:`Process` couples the inputs model (whose JSON schema becomes the OGC process
description), a ``prepare`` step run at submission (parse and validate the region, check the
limits, choose the seed) and the runner that computes it in a worker. Errors found here are
reported before any job exists, as 422 problems pointing at the offending input.
"""

from __future__ import annotations

import math
import secrets
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from typing import Any

from pydantic import BaseModel

import engine

from .control import (
    checked_constraints,
    checked_refinements,
    estimate_or_refuse,
    estimate_subdomains,
    refinements_of,
    stored_tagging,
    subdomains_of,
)
from .document import mesh_from_document
from .geo import GeoError, UnknownCRS
from .geojson import BoundaryInputError, ParsedRegion, parse_region, region_crs
from .inputs import (
    ExecuteRequest,
    MeshDocumentInput,
    MeshExecute,
    MeshInputs,
    QualityExecute,
    QualityInputs,
    SmoothExecute,
    SmoothingInput,
    SmoothInputs,
)
from .problems import Problem
from .settings import Settings

__all__ = [
    "PROCESSES",
    "Prepared",
    "Process",
    "Where",
    "count_rings",
    "estimate_mesh",
    "inputs_at",
    "triangle_cap",
]

#: ``where(input_name) -> JSON pointer`` of an input in the request (for error reports).
Where = Callable[[str], str]


def inputs_at(base: str) -> Where:
    """Inputs found under ``base`` (``/inputs`` in an execute request).

    >>> inputs_at("/inputs")("size")
    '/inputs/size'
    """
    return lambda name: f"{base}/{name}"


@dataclass(frozen=True)
class Prepared:
    """A validated request, ready to store and run."""

    inputs: dict[str, Any]  #: resolved inputs (defaults and seed filled in), as JSON
    seed: int | None
    triangles: int  #: estimated size of the result


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


def estimate_mesh(
    region: engine.Region, sizing: engine.SizingParams, cap: int | None = None
) -> int:
    """Triangles the engine expects for ``region`` at ``sizing``: the engine's own estimator
    (the one the worker checks again), so admission and the engine cannot disagree; counting
    stops past ``cap`` (then the result only says the count is over it).

    >>> square = engine.make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> estimate_mesh(square, engine.SizingParams(size=0.1))
    252
    """
    from engine.sizing import build_size_field

    return int(engine.estimate_triangles(region, build_size_field(region, sizing), cap=cap))


def _smoothing(smoothing: SmoothingInput, where: Where) -> dict[str, Any]:
    """The resolved smoothing input (seed chosen), checked by the engine's own parameters so
    what the worker would refuse is refused now (e.g. alpha = beta = 0)."""
    if smoothing.method not in engine.SMOOTHERS:  # the default may not be installed
        raise Problem(
            422,
            f"unknown smoothing method {smoothing.method!r}; "
            f"choose one of {sorted(engine.SMOOTHERS)}",
            kind="invalid-input",
            pointer=f"{where('smoothing')}/method",
        )
    values = smoothing.model_dump()
    seed = values.pop("seed")
    try:
        values = asdict(engine.SmoothingParams(**values))
    except ValueError as exc:
        raise Problem(422, str(exc), kind="invalid-input", pointer=where("smoothing")) from None
    # Stored with the job: reruns are identical.
    values["seed"] = secrets.randbits(63) if seed is None else seed
    return values


def _limit(value: float, limit: float, what: str, pointer: str) -> None:
    if value > limit:
        raise Problem(
            422,
            f"{what} is {value:.4g}, over the limit of {limit:.4g}",
            kind="limit-exceeded",
            title="Input over a limit",
            pointer=pointer,
        )


def _ga_factor(smoothing: dict[str, Any]) -> int:
    """GA fitness evaluations per interior node (0 for the other smoothers)."""
    if smoothing["method"] != "ga":
        return 0
    return int(smoothing["population"] * smoothing["generations"] * smoothing["max_sweeps"])


def _ga_work(smoothing: dict[str, Any], triangles: int, settings: Settings, where: Where) -> None:
    factor = _ga_factor(smoothing)
    if not factor:
        return
    nodes = max(1, triangles // 2)
    _limit(
        float(nodes * factor),
        settings.ga_work_limit,
        "the GA work (nodes x population x generations x sweeps; its limit is max_ga_work, and"
        " no more than job_timeout x ga_rate)",
        where("smoothing"),
    )


def triangle_cap(smoothing: dict[str, Any], settings: Settings) -> int:
    """The most triangles the real mesh of a ``mesh`` job may have: ``max_triangles``, and for
    the GA the count whose work reaches the GA-work limit (a node per two triangles).

    >>> s = Settings(max_triangles=1000, max_ga_work=1e6, _env_file=None)
    >>> triangle_cap({"method": "ga", "population": 10, "generations": 10, "max_sweeps": 10}, s)
    1000
    >>> triangle_cap({"method": "ga", "population": 100, "generations": 100, "max_sweeps": 10}, s)
    20
    """
    factor = _ga_factor(smoothing)
    if not factor:
        return settings.max_triangles
    return max(1, min(settings.max_triangles, int(2 * settings.ga_work_limit // factor)))


#: Lengths are accepted between these multiples of the region's extent: below, the squares the
#: estimator takes underflow; above, the length means nothing (a triangle per corner already).
LENGTH_RANGE = (1e-9, 1e3)


def _sizing(
    parsed: ParsedRegion, lengths: dict[str, float | None], growth: float, where: Where
) -> engine.SizingParams:
    x0, y0, x1, y1 = parsed.region.bounds
    extent = max(x1 - x0, y1 - y0)
    lo, hi = extent * LENGTH_RANGE[0], extent * LENGTH_RANGE[1]
    for name, value in lengths.items():
        if value is not None and not lo <= value <= hi:
            raise Problem(
                422,
                f"{name} is {value:.4g}; for this region (extent {extent:.4g}) it must be"
                f" between {lo:.4g} and {hi:.4g}",
                kind="invalid-input",
                pointer=where(name),
            )
    size = lengths["size"]
    assert size is not None
    try:
        return engine.SizingParams(size, growth, lengths["size_min"], lengths["size_max"])
    except ValueError as exc:
        raise Problem(422, str(exc), kind="invalid-input", pointer=where("size")) from None


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
        raise Problem(422, exc.message, kind="invalid-input", pointer=crs_at) from None
    except GeoError as exc:  # RegionTooLarge and the like: the region as a whole
        raise Problem(422, exc.message, kind="invalid-boundary", pointer=at) from None
    except (TypeError, ValueError, ArithmeticError, RuntimeWarning) as exc:
        # Input the parser did not foresee (numbers near the float limit overflow, a warning
        # when warnings are errors): still the input's fault, never a server error.
        raise Problem(
            422, f"the boundary could not be read: {exc}", kind="invalid-boundary", pointer=at
        ) from exc


def _prepare_mesh(inputs: MeshInputs, settings: Settings, where: Where) -> Prepared:
    rings, vertices = count_rings(inputs.boundary, settings.max_vertices)
    at = where("boundary")
    _limit(rings, settings.max_rings, "the number of rings", at)
    _limit(vertices, settings.max_vertices, "the number of boundary vertices", at)
    sizes: list[float | None] | None = None  # subdomains: each polygon's own size
    try:
        parsed = _parse(inputs, where)
    except engine.InvalidBoundary as exc:  # polygons sharing edges are subdomains
        parsed, sizes = subdomains_of(
            inputs.boundary, at, region_crs(inputs.boundary, inputs.crs, inputs.coordinates), exc
        )
    # Refinements, constraints and named runs are given in the input CRS and meshed as the
    # region is (lon/lat: projected, sizes in metres).
    geographic = parsed.projection is not None and parsed.projection.geographic
    size = inputs.size
    if size is None:
        h = parsed.properties.get("h")
        if not isinstance(h, int | float) or isinstance(h, bool) or not (0 < h < math.inf):
            raise Problem(
                422,
                "size is required (or a positive 'h' property on the Feature)",
                kind="invalid-input",
                pointer=where("size"),
            )
        size = float(h)
    lengths = {"size": size, "size_min": inputs.size_min, "size_max": inputs.size_max}
    sizing = _sizing(parsed, lengths, inputs.growth, where)
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
    sizing = replace(
        sizing,
        refinements=refinements_of(refinements),
        resample=inputs.resample,
        resample_tolerance=inputs.resample_tolerance,
    )
    smoothing = _smoothing(inputs.smoothing, where)
    if sizes is None:
        triangles = estimate_or_refuse(parsed.region, sizing, settings.max_triangles, where("size"))
    else:
        triangles = estimate_subdomains(
            parsed, sizes, sizing, settings.max_triangles, where("size")
        )
    _ga_work(smoothing, triangles, settings, where)
    if geographic and sizes is None:
        # Lon/lat edges are straight in lon/lat (RFC 7946): split them at the size so the
        # meshed boundary follows them (sizes were checked first, so this stays small).
        parsed = _parse(inputs, where, densify=sizing.size)
    tagging = stored_tagging(inputs.boundary, parsed, at)  # renumbered as the densified rings
    # What the job keeps and the worker gets: the rings as floats in the meshing plane, the CRS
    # names that map the result back, and the resolved parameters, never the client's JSON
    # (whose foreign members may be anything).
    resolved = {
        "parts": parsed.parts,
        "crs": parsed.crs(),
        "size": sizing.size,
        "growth": sizing.growth,
        "size_min": sizing.size_min,
        "size_max": sizing.size_max,
        "resample": sizing.resample,
        "resample_tolerance": sizing.resample_tolerance,
        "swap": inputs.swap,
        "smoothing": smoothing,
        "max_triangles": triangle_cap(smoothing, settings),
        "tagging": tagging,
        "refinements": refinements,
        "constraints": checked_constraints(
            inputs.constraints, parsed.region, parsed.projection, where("constraints"), densify
        ),
        "subdomains": None if sizes is None else {"sizes": sizes},
    }
    return Prepared(resolved, smoothing["seed"], triangles)


def _mesh_size(mesh: MeshDocumentInput, settings: Settings, where: Where) -> int:
    """Check a mesh input's size, then the mesh itself (so a bad mesh is refused up front)."""
    at = where("mesh")
    limit = settings.max_triangles
    _limit(len(mesh.triangles), limit, "the number of triangles", f"{at}/triangles")
    _limit(len(mesh.points), limit, "the number of points", f"{at}/points")
    try:
        mesh_from_document(mesh.model_dump(exclude_none=True))
    except engine.InvalidMesh as exc:
        pointer = at
        if exc.triangle is not None:
            pointer += f"/triangles/{exc.triangle}"
        elif exc.point is not None:
            pointer += f"/{_points_at(mesh)}/{exc.point}"
        raise Problem(422, exc.message, kind="invalid-mesh", pointer=pointer) from None
    except (TypeError, ValueError, ArithmeticError) as exc:
        raise Problem(
            422, f"the mesh could not be read: {exc}", kind="invalid-mesh", pointer=at
        ) from exc
    return len(mesh.triangles)


def _points_at(mesh: MeshDocumentInput) -> str:
    """Where the points a job uses are (the mesh plane's when the document has them)."""
    if mesh.projected is not None:
        return "projected/points"
    return "points_local" if mesh.points_local else "points"


def _mesh_only(mesh: MeshDocumentInput) -> dict[str, Any]:
    """The parts of a mesh document a job uses (a whole result document may be given)."""
    return mesh.model_dump(
        include={"points", "triangles", "points_local", "projected"}, exclude_none=True
    )


def _prepare_smooth(inputs: SmoothInputs, settings: Settings, where: Where) -> Prepared:
    triangles = _mesh_size(inputs.mesh, settings, where)
    smoothing = _smoothing(inputs.smoothing, where)
    _ga_work(smoothing, triangles, settings, where)
    resolved = inputs.model_dump(exclude_none=True)
    resolved["mesh"] = _mesh_only(inputs.mesh)
    resolved["smoothing"] = smoothing
    return Prepared(resolved, smoothing["seed"], triangles)


def _prepare_quality(inputs: QualityInputs, settings: Settings, where: Where) -> Prepared:
    try:
        engine.SmoothingParams(fitness=inputs.fitness, alpha=inputs.alpha, beta=inputs.beta)
    except ValueError as exc:
        raise Problem(422, str(exc), kind="invalid-input", pointer=where("alpha")) from None
    triangles = _mesh_size(inputs.mesh, settings, where)
    resolved = inputs.model_dump(exclude_none=True)
    resolved["mesh"] = _mesh_only(inputs.mesh)
    return Prepared(resolved, None, triangles)


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
            inputs_model=MeshInputs,
            execute_model=MeshExecute,
            runner="service.jobs.runners:mesh",
            prepare=_prepare_mesh,
            keywords=("mesh", "triangulation", "advancing front", "genetic algorithm"),
            outputs=_MESH_OUTPUT,
        ),
        Process(
            id="smooth",
            title="Smooth a mesh",
            description="Swap diagonals and move the interior nodes of an existing mesh.",
            inputs_model=SmoothInputs,
            execute_model=SmoothExecute,
            runner="service.jobs.runners:smooth",
            prepare=_prepare_smooth,
            keywords=("mesh", "smoothing", "genetic algorithm"),
            outputs=_MESH_OUTPUT,
        ),
        Process(
            id="quality",
            title="Assess a mesh",
            description="Per-triangle quality, per-node fitness and summary figures of a mesh.",
            inputs_model=QualityInputs,
            execute_model=QualityExecute,
            runner="service.jobs.runners:quality",
            prepare=_prepare_quality,
            keywords=("mesh", "quality"),
            outputs=_MESH_OUTPUT,
        ),
    )
}
