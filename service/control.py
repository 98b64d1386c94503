"""Mesh control at admission and in the worker: the size-field estimate with its limits, and
the boundary tags of a job (region names and tag runs) as plain JSON and as engine objects.

Kept apart from :mod:`service.processes` so it only calls in.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import orjson
import shapely
from pyproj.exceptions import ProjError
from shapely.geometry import mapping

import engine
from engine.estimate import refuse_by_area
from engine.refinement import InvalidRefinement
from engine.sizing import build_size_field

from .boundary_tags import region_name, tag_runs
from .geo import Projection, project_rings
from .geo.shapes import project_geometry, snap_vertices
from .geojson import LocatedInvalidBoundary, ParsedRegion, build_region, parse_region
from .inputs import RefinementInput
from .refusal import InputRefused

__all__ = [
    "checked_constraints",
    "checked_refinements",
    "estimate_or_refuse",
    "estimate_subdomains",
    "job_region",
    "local_payload",
    "refinement_vertices",
    "refinements_of",
    "run_mesh",
    "stored_tagging",
    "subdomains_of",
    "tagging_of",
]

#: Share of boundary segments shorter than the size past which a refusal explains that every
#: boundary vertex is kept (the boundary, not the area, then drives the triangle count).
_DENSE_SHARE = 0.5
#: Lon/lat constraint vertices this close to a ring (relative to the region's extent) in the
#: plane lie on it in the input: the chord of a projected edge is off its lon/lat line by less.
_SNAP = 1e-5


def _short_share(region: engine.Region, size: float) -> float:
    """The share of boundary segments shorter than ``size``."""
    lengths = np.concatenate([np.hypot(*(np.roll(r, -1, axis=0) - r).T) for r in region.rings])
    return float(np.mean(lengths < size)) if len(lengths) else 0.0


def estimate_or_refuse(
    region: engine.Region, sizing: engine.SizingParams, cap: int, pointer: str
) -> int:
    """The engine's triangle estimate, counting stopped past ``cap``; an ``InputRefused`` at
    ``pointer`` when the size field cannot be built (too many gap samples) or the estimate is
    over ``cap`` (saying why when the boundary's vertices, closer than the size, drive it).
    With ``sizing.resample`` the estimate is of the resampled region, as the engine meshes it."""
    if sizing.resample:
        region = engine.resample_region(region, sizing).region
    try:
        refuse_by_area(region, sizing, cap)
        field = build_size_field(region, sizing)
    except engine.LimitExceeded as exc:
        raise InputRefused(
            str(exc), kind="limit-exceeded", title="Input over a limit", pointer=pointer
        ) from None
    triangles = int(engine.estimate_triangles(region, field, cap=cap))
    if triangles > cap:
        detail = (
            f"the estimated number of triangles is over {triangles:,}, over the limit of {cap:,}"
        )
        if not sizing.resample and _short_share(region, sizing.size) > _DENSE_SHARE:
            detail += (
                f"; most of the boundary's {region.n_vertices:,} vertices are closer together"
                " than the size, and every boundary vertex is kept as a mesh node: use"
                " `resample: true` (CLI --resample) to re-discretise it to the size, or use a"
                " larger size or simplify the boundary"
            )
        raise InputRefused(
            detail, kind="limit-exceeded", title="Input over a limit", pointer=pointer
        )
    return triangles


def _features(
    boundary: Any, parts: int, pointers: Any, at: str
) -> list[tuple[dict[str, Any], int, int, str]]:
    """(properties, first part, end part, pointer) of each Feature of ``boundary``; one entry
    without properties when it is a bare geometry."""
    if isinstance(boundary, dict) and boundary.get("type") == "Feature":
        props = boundary.get("properties") or {}
        return [(props, 0, parts, at)]
    if isinstance(boundary, dict) and boundary.get("type") == "FeatureCollection":
        out = []
        start = 0
        for i, feat in enumerate(boundary["features"]):
            ptr = f"{at}/features/{i}"
            stop = start
            while stop < parts and pointers[stop][0].startswith(f"{ptr}/"):
                stop += 1
            out.append(
                ((feat.get("properties") or {}) if isinstance(feat, dict) else {}, start, stop, ptr)
            )
            start = stop
        return out
    return [({}, 0, parts, at)]


def _renumber(run: dict[str, Any], projection: Projection | None, part: int) -> dict[str, Any]:
    """A run's ``from`` / ``to`` (input vertices) as vertices of the densified lon/lat ring the
    job meshes: each input vertex stays a vertex, the first of the pieces of its edge."""
    if projection is None or projection.origins is None:
        return run
    starts = projection.origins[part + run.get("polygon", 0)][run.get("ring", 0)]
    at = {k: int(np.searchsorted(starts, run[k])) for k in ("from", "to")}
    return {**run, **at}


def _input_polygons(parsed: ParsedRegion, start: int, stop: int) -> list[list[Any]]:
    """Parts ``start:stop`` as lists of rings numbered as the input's (densified lon/lat rings:
    their input vertices only)."""
    origins = parsed.projection.origins if parsed.projection is not None else None
    out = []
    for k in range(start, stop):
        outer, holes = parsed.parts[k]
        rings: list[Any] = [outer, *holes]
        if origins is not None:
            rings = [
                np.asarray(r)[np.searchsorted(o, np.arange(int(o.max()) + 1))]
                for r, o in zip(rings, origins[k], strict=True)
            ]
        out.append(rings)
    return out


def stored_tagging(boundary: Any, parsed: ParsedRegion, at: str) -> dict[str, Any]:
    """The tagging a job keeps (plain JSON): each part's region name and each Feature's tag
    runs, checked now so a bad run is a 422 pointing at it. Runs are kept in the numbering of
    the rings the job meshes (lon/lat rings split at the size: renumbered)."""
    names: list[str | None] = []
    features = []
    for props, start, stop, ptr in _features(boundary, len(parsed.parts), parsed.ring_pointers, at):
        name = region_name(props)
        # A MultiPolygon Feature's polygons are regions of their own: "name", "name-1", ...
        names += [name if k == 0 or name is None else f"{name}-{k}" for k in range(stop - start)]
        tag_runs(props, _input_polygons(parsed, start, stop), ptr)  # a 422 at a faulty run
        runs = [
            _renumber(
                {k: run[k] for k in ("name", "polygon", "ring", "from", "to") if k in run},
                parsed.projection,
                start,
            )
            for run in props.get("tags", [])
        ]
        if runs:
            features.append({"parts": [start, stop], "tags": runs})
    return {"names": names, "features": features}


def tagging_of(stored: dict[str, Any] | None, parts: Any) -> engine.Tagging:
    """The engine's :class:`~engine.Tagging` of a job's stored tagging on ``parts`` (the rings
    in the region's own frame, as the stored parts after any projection)."""
    if not stored:
        return engine.Tagging()
    runs: list[engine.TagRun] = []
    for feature in stored["features"]:
        start, stop = feature["parts"]
        polygons = [[outer, *holes] for outer, holes in parts[start:stop]]
        runs += tag_runs({"tags": feature["tags"]}, polygons)
    return engine.Tagging(names=stored["names"], runs=runs)


def refinements_of(stored: Sequence[Mapping[str, Any]]) -> tuple[engine.Refinement, ...]:
    """The engine's refinements of a job's stored ``refinements``."""
    return tuple(
        engine.Refinement(r["geometry"], float(r["size"]), r.get("growth")) for r in stored
    )


def _in_plane(
    geometry: Mapping[str, Any], projection: Projection | None, densify: float | None, at: str
) -> dict[str, Any]:
    """``geometry`` (checked GeoJSON, in the input CRS) in the meshing plane; a 422 at ``at``
    when the projection cannot map it (a position outside the CRS's range)."""
    try:
        return project_geometry(geometry, projection, densify)
    except (ProjError, ValueError, TypeError, KeyError) as exc:
        raise InputRefused(
            f"the geometry cannot be projected: {exc}", kind="invalid-input", pointer=at
        ) from None


def checked_refinements(
    refinements: Sequence[RefinementInput],
    projection: Projection | None,
    vertices: int,
    limit: int,
    at: str,
    densify: float | None = None,
) -> list[dict[str, Any]]:
    """The refinements as a job keeps them (plain GeoJSON in the meshing plane: lon/lat ones
    projected as the region is, lines split at ``densify``); a 422 at ``at/i`` for one the
    engine refuses, and at ``at`` when their vertices and the boundary's (``vertices``) pass
    ``limit``."""
    out = []
    for i, r in enumerate(refinements):
        try:
            shape = engine.Refinement(r.geometry, r.size, r.growth).shape()
            plane = _in_plane(mapping(shape), projection, densify, f"{at}/{i}/geometry")
            shape = engine.Refinement(plane, r.size, r.growth).shape()
        except InvalidRefinement as exc:
            raise InputRefused(str(exc), kind="invalid-input", pointer=f"{at}/{i}") from None
        vertices += int(shapely.get_num_coordinates(shape))
        _check_vertices(vertices, limit, "the boundary's and the refinements'", f"{at}/{i}")
        # Stored as shapely writes it back: plain GeoJSON, never the client's members.
        kept = {"geometry": orjson.loads(orjson.dumps(mapping(shape))), "size": r.size}
        out.append(kept if r.growth is None else {**kept, "growth": r.growth})
    return out


def _check_vertices(count: int, limit: int | None, what: str, pointer: str) -> None:
    """A 422 at ``pointer`` when ``count`` (``what`` vertices) is over ``limit`` (None: none)."""
    if limit is not None and count > limit:
        raise InputRefused(
            f"{what} vertices are over the limit of {limit:,}",
            kind="limit-exceeded",
            title="Input over a limit",
            pointer=pointer,
        )


def refinement_vertices(refinements: Sequence[Mapping[str, Any]]) -> int:
    """The vertices of refinements as :func:`checked_refinements` keeps them."""
    return sum(
        int(shapely.get_num_coordinates(shapely.geometry.shape(r["geometry"]))) for r in refinements
    )


def checked_constraints(
    obj: Any,
    region: engine.Region,
    projection: Projection | None,
    at: str,
    densify: float | None = None,
    vertices: int = 0,
    limit: int | None = None,
) -> dict[str, Any]:
    """The constraints as a job keeps them: ``geometries`` (plain GeoJSON in the meshing plane
    of ``region``: lon/lat ones projected as the region is, lines split at ``densify``) and
    each one's ``names`` (its Feature's ``name``); a 422 at the faulty one when the engine's own
    checks (kind of geometry, inside the region, which may be subdomains) refuse it, and at the
    one whose vertices take the count past ``limit`` (counting from ``vertices``: the
    boundary's and the refinements')."""
    if obj is None:
        return {"geometries": [], "names": []}
    if isinstance(obj, dict) and obj.get("type") == "FeatureCollection":
        feats = obj.get("features")
        items = [
            (f, f"{at}/features/{i}")
            for i, f in enumerate(feats if isinstance(feats, list) else [])
        ]
    else:
        items = [(obj, at)]
    geoms: list[Any] = []
    names: list[str | None] = []
    pointers: list[str] = []
    for item, ptr in items:
        if isinstance(item, dict) and item.get("type") == "Feature":
            geoms.append(item.get("geometry"))
            props = item.get("properties")
            names.append(region_name(props) if isinstance(props, dict) else None)
            pointers.append(f"{ptr}/geometry")
        else:
            geoms.append(item)
            names.append(None)
            pointers.append(ptr)
    plane = []
    rings = shapely.union_all([p.to_shapely().boundary for p in region.parts])
    for g, ptr in zip(geoms, pointers, strict=True):
        try:
            shape = shapely.geometry.shape(
                _in_plane(mapping(shapely.geometry.shape(g)), projection, densify, ptr)
            )
        except (AttributeError, KeyError, TypeError, ValueError, shapely.errors.ShapelyError):
            plane.append(g)  # not a geometry: the engine's check below names it
            continue
        vertices += int(shapely.get_num_coordinates(shape))
        what = "the boundary's, the refinements' and the constraints'"
        _check_vertices(vertices, limit, what, ptr)
        if projection is not None and projection.geographic:
            # A lon/lat position on a ring's edge lands off its chord in the plane by a
            # fraction of a metre: put it on the ring, as it was in the input.
            shape = snap_vertices(
                shape,
                rings,
                _SNAP
                * max(region.bounds[2] - region.bounds[0], region.bounds[3] - region.bounds[1]),
            )
        plane.append(mapping(shape))
    try:
        # The engine's own checks, cheap next to meshing: refused now, not in the worker.
        shapes = engine.check_constraints(plane, region)
    except engine.InvalidConstraint as exc:
        where = pointers[exc.index] if exc.index < len(pointers) else at
        raise InputRefused(str(exc), kind="invalid-input", pointer=where) from None
    plain = [orjson.loads(orjson.dumps(mapping(s))) for s in shapes]
    return {"geometries": plain, "names": names}


def run_mesh(
    payload: dict[str, Any],
    region: engine.Region,
    params: engine.PipelineParams,
    rng: np.random.Generator,
    progress: engine.ProgressFn,
    should_stop: engine.StopFn,
) -> tuple[engine.Result, engine.MeshTags]:
    """A ``mesh`` job's engine run, with its constraints when it has some, and its tags."""
    constraints = payload.get("constraints") or {}
    geoms, names = constraints.get("geometries") or [], constraints.get("names") or []
    # The stored parts are in the meshing plane, and the named runs in its numbering.
    tagging = tagging_of(payload.get("tagging"), payload["parts"])
    # With resample, the ends of named runs stay ring vertices and the runs are mapped onto
    # the resampled rings.
    ends = np.asarray([np.asarray(r.path)[k] for r in tagging.runs for k in (0, -1)])
    lines: dict[str, Any] = {}
    pinned = np.empty(0, dtype=np.int64)
    boundary: engine.Resampled | None = None
    if payload.get("subdomains"):
        sizes = payload["subdomains"]["sizes"]
        sub = engine.mesh_subdomains(
            payload["parts"], params, sizes, rng, geoms, progress, should_stop, ends
        )
        result, region, boundary = sub.result, sub.region, sub.boundary
        if sub.constraints is not None:
            lines, pinned = sub.constraints.lines(names), sub.constraints.nodes
    elif geoms:
        out = engine.mesh_with_constraints(
            region, params, geoms, rng, progress, should_stop, keep=ends.reshape(-1, 2)
        )
        lines, pinned = out.lines(names), out.nodes
        result, boundary = out.result, out.boundary
    elif params.sizing.resample and tagging.runs:
        boundary = engine.resample_region(region, params.sizing, keep=ends)
        sizing = replace(params.sizing, resample=False)
        result = engine.mesh_then_smooth(
            boundary.region, replace(params, sizing=sizing), rng, progress, should_stop
        )
        result.smoothed.summary["boundary"] = boundary.summary()
    else:
        result = engine.mesh_then_smooth(
            region, params, rng, progress=progress, should_stop=should_stop
        )
    if boundary is not None:
        if not payload.get("subdomains"):  # theirs is split along the shared edges
            region = boundary.region
        runs = [engine.TagRun(r.name, boundary.map_path(r.path)) for r in tagging.runs]
        tagging = engine.Tagging(tagging.names, runs)
    return result, engine.tag_mesh(result.smoothed.mesh, region, tagging, lines, pinned)


def local_payload(
    boundary: Any, parsed: ParsedRegion, inputs: Mapping[str, Any], size: float | None = None
) -> dict[str, Any]:
    """What :func:`run_mesh` needs besides the parameters, for the command line: the stored
    tagging, refinements and constraints of ``inputs`` (lon/lat ones projected as the region,
    their lines split at ``size``); ``ValueError`` naming the faulty one."""
    projection = parsed.projection
    densify = size if projection is not None and projection.geographic else None
    try:
        given = [RefinementInput.model_validate(r) for r in inputs.get("refinements", [])]
        refinements = checked_refinements(
            given, projection, parsed.region.n_vertices, 10**9, "/refinements", densify
        )
        return {
            "parts": parsed.parts,
            "crs": parsed.crs(),
            "tagging": stored_tagging(boundary, parsed, ""),
            "refinements": refinements,
            "constraints": checked_constraints(
                inputs.get("constraints"), parsed.region, projection, "/constraints", densify
            ),
        }
    except InputRefused as exc:
        raise ValueError(f"{exc.pointer}: {exc.detail}") from None


def _pieces(boundary: Any, at: str) -> list[tuple[Any, str, Any]]:
    """(polygon input, its pointer, its ``h``) of each polygon a subdomain boundary lists."""
    if isinstance(boundary, dict) and boundary.get("type") == "FeatureCollection":
        return [
            (f, f"{at}/features/{i}", (f.get("properties") or {}).get("h"))
            for i, f in enumerate(boundary.get("features") or [])
        ]
    h = None
    if isinstance(boundary, dict) and boundary.get("type") == "Feature":
        h = (boundary.get("properties") or {}).get("h")
        boundary, at = boundary.get("geometry"), f"{at}/geometry"
    if isinstance(boundary, dict) and boundary.get("type") == "MultiPolygon":
        coords = boundary.get("coordinates") or []
        # A polygon's rings as a bare list, so its rings' pointers are {at}/coordinates/k/i.
        return [(c, f"{at}/coordinates/{k}", h) for k, c in enumerate(coords)]
    return []


def subdomains_of(
    boundary: Any, at: str, crs: str | None, error: LocatedInvalidBoundary
) -> tuple[ParsedRegion, list[float | None]]:
    """``boundary`` as subdomains (polygons sharing edges, interiors apart) and each one's own
    ``h``; re-raises ``error`` (the whole region's) when it is not that case, and a located
    422 for polygons that overlap. With a ``crs`` the polygons are projected together (one
    plane, so shared vertices stay shared; lon/lat edges are not split at the size)."""
    pieces = _pieces(boundary, at)
    if len(pieces) < 2:
        raise error
    parsed = [parse_region(obj, pointer=ptr) for obj, ptr, _ in pieces]
    shapes = [p.region.to_shapely() for p in parsed]
    shared = False
    for j in range(len(shapes)):
        for i in range(j):
            common = shapes[i].intersection(shapes[j])
            if common.area > 1e-9 * min(shapes[i].area, shapes[j].area):
                raise InputRefused(
                    f"polygon {j} overlaps polygon {i}: subdomains may share edges only",
                    kind="invalid-boundary",
                    pointer=pieces[j][1],
                )
            shared = shared or common.length > 0
    if not shared:
        raise error
    hs = [
        float(h) if isinstance(h, int | float) and not isinstance(h, bool) and h > 0 else None
        for _, _, h in pieces
    ]
    parts = [part for p in parsed for part in p.parts]
    projection = None
    if crs is not None:
        projection = project_rings(parts, crs)
        parts = [(o.tolist(), [h.tolist() for h in hs]) for o, hs in projection.parts]
    # Put together unchecked: the parts touch, which engine.make_region refuses.
    region = engine.Region(tuple(engine.make_region([part]).parts[0] for part in parts))
    pointers = tuple(ptrs for p in parsed for ptrs in p.ring_pointers)
    return ParsedRegion(region, parts, pointers, parsed[0].properties, projection), hs


def estimate_subdomains(
    parsed: ParsedRegion, sizes: list[float | None], sizing: engine.SizingParams, cap: int, at: str
) -> int:
    """The triangles the subdomains expect, each part at its own size (the job's when none); a
    refusal names the polygon, and points at its own ``h`` when it has one."""
    total = 0
    for k, (part, h) in enumerate(zip(parsed.region.parts, sizes, strict=True)):
        own = replace(sizing, size=h or sizing.size)
        where = _own_size_pointer(parsed.ring_pointers[k][0]) if h else at
        try:
            total += estimate_or_refuse(engine.Region((part,)), own, max(1, cap - total), where)
        except InputRefused as exc:
            raise InputRefused(
                f"polygon {k}: {exc.detail}", kind=exc.kind, title=exc.title, pointer=exc.pointer
            ) from None
    return total


def _own_size_pointer(ring: str) -> str:
    """The pointer of the ``properties.h`` that sized the polygon whose first ring is at
    ``ring``: its Feature's (in a FeatureCollection, or the Feature of a MultiPolygon).

    >>> _own_size_pointer("/inputs/boundary/features/2/geometry/coordinates/0")
    '/inputs/boundary/features/2/properties/h'
    """
    return ring.split("/geometry/")[0] + "/properties/h"


def job_region(payload: dict[str, Any]) -> tuple[engine.Region, dict[str, Any] | None]:
    """A job's region (in its meshing plane) and its CRS facts; subdomains' parts are put
    together unchecked (they touch, which :func:`engine.make_region` refuses) as
    :func:`run_mesh` nodes them. Jobs stored before the ``crs`` input keep lon/lat rings under
    ``coordinates: "wgs84"``: those are projected here."""
    crs = payload.get("crs")
    if payload.get("subdomains"):
        parts = [engine.make_region([part]).parts[0] for part in payload["parts"]]
        return engine.Region(tuple(parts)), crs
    if crs is None and payload.get("coordinates") == "wgs84":
        projection = project_rings(payload["parts"], "OGC:CRS84")
        payload["parts"] = [(o.tolist(), [h.tolist() for h in hs]) for o, hs in projection.parts]
        crs = projection.describe()
    return build_region(payload["parts"]), crs
