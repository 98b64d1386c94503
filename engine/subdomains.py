"""Subdomains: polygons that share edges (or parts of edges) meshed as one conforming mesh, each
with its own size, each triangle knowing its polygon.

1. Every polygon is validated alone; overlapping polygons are an :class:`InvalidBoundary` at a
   point of the overlap.
2. Rings are noded: a vertex of one polygon lying on another's edge becomes a vertex of both.
3. Each shared segment is split once, to the smaller of its two polygons' size fields
   (``ceil`` of the integral of ``ds / h``).
4. Each polygon is meshed alone (its size: its own ``h``; a neighbour's smaller ``h`` grades in
   from their common boundary as a refinement), its ring holding those split points and no
   piece between two of them split again (its other segments are discretised to its own
   field; no later stage of the mesher adds, removes or moves a node of those pieces), so both
   sides have exactly the same nodes; the meshes are merged on them.
5. Constraints (lines and points, :mod:`engine.constraints`) are put into the merged mesh,
   their lines noded where they cross an interface; no repair flip crosses an interface.
6. Swapping (diagonals, then valence) never flips an interface or constraint edge and
   smoothing never moves an interface or constraint node
   (:class:`~engine.constraints.PinnedMesh`), so the regions keep their polygons' shapes; the
   post-processing and the ``timings`` are :func:`engine.mesh_then_smooth`'s.

With ``sizing.resample`` the noded rings and the constraint lines are resampled together
(:func:`engine.resample.resample_parts_constraints`) before step 3: each shared stretch once,
branch points, corners and constraint vertices on rings kept; the lines keep their ends,
corners, junctions and crossings (with each other and with the rings).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from .boundary import PartInput, PolygonPart, Region, make_region
from .constraints import (
    Constrained,
    PinnedMesh,
    check_constraints,
    check_inside,
    improve_held,
    insert_constraints,
    plain_geometries,
    split_segment,
)
from .errors import Cancelled, InvalidBoundary, MeshingError
from .mesh import Mesh, validate_mesh
from .params import PipelineParams, SizingParams
from .pipeline import mesh_region
from .refinement import Refinement
from .resample import Resampled, insert_points, resample_parts_constraints
from .result import ProgressFn, Result, StopFn
from .sizing import SizeField, build_size_field
from .tags import interface_edges

__all__ = ["PinnedMesh", "Subdomains", "improve_held", "mesh_subdomains", "split_segment"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Pieces of boundary closer than this fraction of the extent coincide.
_TOL = 1e-9


@dataclass(frozen=True)
class Subdomains:
    """What :func:`mesh_subdomains` returns."""

    result: Result  #: the pipeline's stages, as :func:`engine.mesh_then_smooth` returns them
    region: Region  #: the noded polygons (a region whose parts touch: for engine.tags)
    triangle_region: IntArray  #: (m,) 1-based polygon of each final triangle
    #: The constraints put in (their edges, nodes and owners; ``result`` is the same), if any.
    constraints: Constrained | None = None
    #: The resampling (its region: the resampled polygons, unsplit), with ``sizing.resample``.
    boundary: Resampled | None = None


def _check_overlaps(polys: list[shapely.Polygon], tol: float) -> None:
    tree = shapely.STRtree(polys)
    left, right = tree.query(polys, predicate="intersects")
    for i, j in zip(left.tolist(), right.tolist(), strict=True):
        if i < j:
            common = polys[i].intersection(polys[j])
            if common.area > tol * tol:
                p = common.representative_point()
                raise InvalidBoundary(
                    f"polygons {i} and {j} overlap near ({p.x:.6g}, {p.y:.6g}); "
                    "subdomains may share edges but not area",
                    part=j,
                    location=(p.x, p.y),
                )


def _key(a: FloatArray, b: FloatArray) -> tuple[float, float, float, float]:
    return (float(a[0]), float(a[1]), float(b[0]), float(b[1]))


def _split_shared(
    parts: list[PolygonPart], fields: list[SizeField], tol: float
) -> dict[tuple[float, float, float, float], FloatArray]:
    """The split points of every shared segment, split once to the smaller of its two
    polygons' fields, by its ends in either direction."""
    boundaries = [p.to_shapely().boundary for p in parts]
    done: dict[tuple[float, float, float, float], FloatArray] = {}
    for i, part in enumerate(parts):
        for ring in part.rings:
            for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True):
                if _key(a, b) in done:  # the neighbour split it the other way
                    continue
                mid = shapely.Point((a + b) / 2)
                other = [
                    j for j in range(len(parts)) if j != i and boundaries[j].distance(mid) < tol
                ]
                if other:
                    pts = split_segment(a, b, [fields[i], fields[other[0]]])
                    done[_key(a, b)], done[_key(b, a)] = pts, pts[::-1]
    return done


def _with_shared(
    ring: FloatArray, shared: Mapping[tuple[float, float, float, float], FloatArray]
) -> FloatArray:
    """``ring`` with the split points of its shared segments inserted."""
    pieces = []
    for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True):
        pieces += [a[None], shared.get(_key(a, b), ring[:0])]
    return np.concatenate(pieces)


def _pieces(
    shared: Mapping[tuple[float, float, float, float], FloatArray],
) -> set[tuple[float, float, float, float]]:
    """The pieces between consecutive split points of the shared segments, either way."""
    return {
        key
        for (a0, a1, b0, b1), pts in shared.items()
        for u, v in itertools.pairwise([(a0, a1), *map(tuple, pts.tolist()), (b0, b1)])
        for key in (u + v, v + u)
    }


def _sizing(
    params: SizingParams, sizes: Sequence[float | None], parts: list[PolygonPart], i: int
) -> SizingParams:
    """Part ``i``'s sizing: its own size; smaller neighbours grade in from their boundaries."""
    own = sizes[i] or params.size
    near = tuple(
        Refinement(shapely.geometry.mapping(parts[j].to_shapely().boundary), h)
        for j, h in enumerate(sizes)
        if j != i and h is not None and h < own
    )
    return replace(params, size=own, refinements=params.refinements + near)


def _merge(meshes: list[Mesh]) -> tuple[Mesh, IntArray]:
    """One mesh of ``meshes``, identical points merged, and the 1-based part of each triangle."""
    pts = np.concatenate([m.points for m in meshes])
    offsets = np.cumsum([0] + [m.n_points for m in meshes])
    tris = np.concatenate([m.triangles + o for m, o in zip(meshes, offsets, strict=False)])
    unique, inverse = np.unique(pts, axis=0, return_inverse=True)
    region = np.concatenate([np.full(m.n_triangles, i + 1) for i, m in enumerate(meshes)])
    return Mesh(unique, inverse.ravel()[tris]), region.astype(np.int64)


def mesh_subdomains(
    parts: Sequence[PartInput],
    params: PipelineParams,
    sizes: Sequence[float | None] = (),
    rng: np.random.Generator | None = None,
    constraints: Sequence[Mapping[str, Any]] = (),
    progress: ProgressFn | None = None,
    should_stop: StopFn | None = None,
    keep: ArrayLike = (),
) -> Subdomains:
    """Mesh polygons that may share edges as one conforming mesh, put ``constraints`` (as
    :func:`engine.mesh_with_constraints` takes them) into it, then swap and smooth it with
    interface and constraint edges and nodes held; ``sizes[i]`` is polygon ``i``'s size
    (``None``: the job's). Reports ``progress`` (``boundary``, ``mesh`` by polygon, ``swap``,
    ``smooth``) and polls ``should_stop`` as :func:`engine.mesh_then_smooth` does. With
    ``sizing.resample`` the rings are resampled together, ``keep`` points (the ends of named
    runs) and constraint vertices that are ring vertices kept, and the summary's ``boundary``
    reports the deviation (as :func:`engine.mesh_then_smooth`'s).

    >>> left = ([[0, 0], [1, 0], [1, 1], [0, 1]], [])
    >>> right = ([[1, 0], [2, 0], [2, 1], [1, 1], [1, 0.5]], [])
    >>> from engine.params import SmoothingParams
    >>> params = PipelineParams(SizingParams(0.25), smoothing=SmoothingParams("none"))
    >>> sub = mesh_subdomains([left, right], params, sizes=[None, 0.1])
    >>> sorted(set(sub.triangle_region.tolist())), sub.result.smoothed.summary["inverted"]
    ([1, 2], 0)
    """
    rng = rng if rng is not None else np.random.default_rng(0)
    progress = progress or _quiet
    stop = should_stop or _never
    started = time.perf_counter()
    progress("boundary", 0.0)
    regions = []
    for i, part in enumerate(parts):
        try:
            regions.append(make_region([part]))
        except InvalidBoundary as exc:
            raise InvalidBoundary(
                f"polygon {i}: {exc}",
                part=i,
                ring=exc.ring,
                vertex=exc.vertex,
                location=exc.location,
            ) from None
    own = [r.parts[0] for r in regions]
    x0 = min(r.bounds[0] for r in regions)
    x1 = max(r.bounds[2] for r in regions)
    y0 = min(r.bounds[1] for r in regions)
    y1 = max(r.bounds[3] for r in regions)
    tol = _TOL * max(x1 - x0, y1 - y0)
    _check_overlaps([p.to_shapely() for p in own], tol)
    corners = np.unique(np.concatenate([r for p in own for r in p.rings]), axis=0)
    noded = [
        PolygonPart(
            insert_points(p.outer, corners, tol, True),
            tuple(insert_points(h, corners, tol, True) for h in p.holes),
        )
        for p in own
    ]
    sizes = list(sizes) + [None] * (len(parts) - len(sizes))
    geoms = check_constraints(constraints, Region(tuple(noded))) if constraints else []
    boundary, base, deviation = None, replace(params.sizing, resample=False), 0.0
    if params.sizing.resample:  # once for all, so that shared stretches stay shared
        sizing = [_sizing(params.sizing, sizes, noded, i) for i in range(len(noded))]
        boundary, geoms, deviation = resample_parts_constraints(noded, sizing, geoms, keep)
        noded = list(boundary.region.parts)
        check_inside(geoms, boundary.region)
    sizing = [_sizing(base, sizes, noded, i) for i in range(len(noded))]
    fields = [build_size_field(Region((p,)), s) for p, s in zip(noded, sizing, strict=True)]
    shared = _split_shared(noded, fields, tol)
    split = [
        PolygonPart(_with_shared(p.outer, shared), tuple(_with_shared(h, shared) for h in p.holes))
        for p in noded
    ]
    timings = {"boundary": time.perf_counter() - started, "mesh": 0.0}
    meshes = []
    whole = _pieces(shared)
    for k, (p, s) in enumerate(zip(split, sizing, strict=True)):
        if stop():
            raise Cancelled("stopped while meshing the subdomains")
        progress("mesh", k / len(noded))
        got_mesh, took = mesh_region(
            Region((p,)),
            s,
            params.relax,
            stop,
            params.max_triangles,
            held_sides=whole,
        )
        meshes.append(got_mesh)
        for stage, seconds in took.items():
            timings[stage] += seconds
    t = time.perf_counter()
    mesh, region = _merge(meshes)
    try:
        mesh = validate_mesh(mesh.points, mesh.triangles)
    except ValueError as exc:
        raise MeshingError(f"the subdomain meshes do not conform: {exc}") from None
    outline = shapely.union_all([p.to_shapely() for p in noded])
    if (
        abs(
            float(
                np.hypot(
                    *(
                        mesh.points[mesh.boundary_edges[:, 1]]
                        - mesh.points[mesh.boundary_edges[:, 0]]
                    ).T
                ).sum()
            )
            - outline.length
        )
        > 1e-6 * outline.length
    ):
        raise MeshingError("the subdomain meshes do not conform along a shared edge")
    interfaces, _ = interface_edges(mesh.triangles, region)
    held = np.zeros(mesh.n_points, dtype=bool)
    held[interfaces.ravel()] = True
    got = None
    if geoms:
        got = insert_constraints(mesh, Region(tuple(split)), geoms, fields, region, held, stop)
        mesh, region = got.mesh, got.label
        held = np.r_[held, np.zeros(mesh.n_points - len(held), dtype=bool)] | got.pinned
    progress("mesh", 1.0)
    # No flip crosses an interface, so triangles keep their regions through swapping.
    interfaces, _ = interface_edges(mesh.triangles, region)
    locked = interfaces if got is None else np.concatenate([interfaces, got.edges])
    timings["mesh"] += time.perf_counter() - t
    result = improve_held(mesh, locked, held, params, rng, progress, should_stop, timings, started)
    if geoms:
        result.parameters["constraints"] = plain_geometries(geoms)
    if boundary is not None:
        result.smoothed.summary["boundary"] = boundary.summary()
        if geoms:
            result.smoothed.summary["boundary"]["constraints_max_deviation"] = deviation
    return Subdomains(
        result=result,
        region=Region(tuple(split)),
        triangle_region=region,
        constraints=None
        if got is None
        else Constrained(
            result, got.edges, got.edge_constraint, np.flatnonzero(got.pinned).astype(np.int64)
        ),
        boundary=boundary,
    )


def _quiet(stage: str, fraction: float) -> None:
    del stage, fraction


def _never() -> bool:
    return False
