"""Constraints: lines that must be chains of mesh edges and points that must be mesh nodes.

The region is meshed as usual; the constraints are then put into the mesh by local repair, so
the front needs to know nothing about them:

1. constraint lines are noded where they cross (the crossing becomes a point of both) and split
   at the local size (as shared subdomain edges are, :func:`engine.subdomains.split_segment`);
2. each constraint point takes the nearest free interior node when moving it there leaves its
   triangles valid, else it is inserted (splitting the triangle, or the edge, it lies on);
3. each piece of line is recovered by flipping the edges that cross it (Sloan's algorithm: some
   crossing edge always has a convex quadrilateral);
4. swapping and smoothing then hold the constraint edges and nodes
   (:func:`engine.subdomains.improve_held`).

Constraints outside the region, or nearly touching each other or the boundary without meeting
it, are an :class:`InvalidConstraint` naming the constraint's index and a location.
"""

from __future__ import annotations

import itertools
import json
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np
import shapely
import shapely.geometry
from numpy.typing import ArrayLike, NDArray

from .boundary import Region
from .errors import Cancelled, EngineError
from .mesh import Mesh
from .params import PipelineParams
from .pipeline import improve_mesh, mesh_region
from .repair import Repair
from .resample import Resampled, resample_constraints
from .result import ProgressFn, Result, StopFn
from .sizing import SizeField, build_size_field

__all__ = [
    "Constrained",
    "Inserted",
    "InvalidConstraint",
    "PinnedMesh",
    "check_constraints",
    "check_inside",
    "improve_held",
    "insert_constraints",
    "mesh_with_constraints",
    "plain_geometries",
    "split_segment",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Pieces closer than this fraction of the local size without meeting are refused.
_NEAR = 0.05


class InvalidConstraint(EngineError, ValueError):
    """A constraint that cannot be put into the mesh; ``index`` is its place in the input."""

    def __init__(
        self, message: str, *, index: int, location: tuple[float, float] | None = None
    ) -> None:
        super().__init__(message)
        self.index = index
        self.location = location


@dataclass(frozen=True)
class PinnedMesh(Mesh):
    """A mesh whose ``pinned`` nodes count as boundary nodes, so that no smoother moves them."""

    pinned: BoolArray = field(default_factory=lambda: np.zeros(0, dtype=bool), repr=False)

    @cached_property
    def boundary_nodes(self) -> BoolArray:
        mask: BoolArray = Mesh.boundary_nodes.func(self)  # type: ignore[attr-defined]
        return mask | self.pinned if len(self.pinned) else mask


def split_segment(a: FloatArray, b: FloatArray, fields: Sequence[SizeField]) -> FloatArray:
    """Points splitting ``a -> b`` into ``ceil(integral of ds / h)`` equal pieces of that
    integral, ``h`` the smaller of ``fields`` (sampled at 64 points, then again at a quarter of
    the smallest size found)."""
    return split_segments(np.asarray(a)[None], np.asarray(b)[None], fields)[0]


def split_segments(a: FloatArray, b: FloatArray, fields: Sequence[SizeField]) -> list[FloatArray]:
    """:func:`split_segment` of each segment ``a[k] -> b[k]``, the same points, with the size
    fields evaluated twice for all of them rather than twice per segment (a 20,000-vertex line
    spent most of its splitting time in those calls)."""
    k = len(a)
    if k == 0:
        return []
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    first = np.linspace(0.0, 1.0, 64)
    xy = (a[:, None, :] + first[None, :, None] * d[:, None, :]).reshape(-1, 2)
    h = np.min([f(xy) for f in fields], axis=0).reshape(k, 64)
    counts = [
        int(min(max(64, math.ceil(4 * float(length[i]) / float(h[i].min()))), 4_000_000))
        for i in range(k)
    ]
    ts = [np.linspace(0.0, 1.0, m) for m in counts]
    xy = np.concatenate([a[i] + ts[i][:, None] * d[i] for i in range(k)])
    sizes = np.min([f(xy) for f in fields], axis=0)
    out = []
    at = 0
    for i in range(k):
        t, inv = ts[i], 1.0 / sizes[at : at + counts[i]]
        at += counts[i]
        cum = np.concatenate(
            [[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(t) * float(length[i]))]
        )
        n = max(math.ceil(cum[-1] - 1e-9), 1)
        inner = np.interp(cum[-1] * np.arange(1, n) / n, cum, t)
        out.append(a[i] + inner[:, None] * d[i])
    return out


@dataclass(frozen=True)
class Constrained:
    """What :func:`mesh_with_constraints` returns."""

    result: Result
    edges: IntArray  #: (k, 2) mesh edges along constraint lines
    edge_constraint: IntArray  #: (k,) the input index of each edge's constraint
    nodes: IntArray  #: mesh nodes of every constraint (points, line vertices and splits)
    region: Region | None = None  #: the region meshed (resampled, with ``sizing.resample``)
    boundary: Resampled | None = None  #: the resampling, with ``sizing.resample``

    def lines(self, names: Sequence[str | None] = ()) -> dict[str, IntArray]:
        """The constraint edges by name (``names[i]``, else ``constraint-i``), for
        :func:`engine.tags.tag_mesh`."""
        given = list(names) + [None] * (int(self.edge_constraint.max(initial=-1)) + 1)
        out: dict[str, list[IntArray]] = {}
        for i in np.unique(self.edge_constraint).tolist():
            name = given[i] or f"constraint-{i}"
            out.setdefault(name, []).append(self.edges[self.edge_constraint == i])
        return {k: np.concatenate(v) for k, v in out.items()}


def _geometries(constraints: Sequence[Mapping[str, Any]]) -> list[shapely.Geometry]:
    out = []
    for i, c in enumerate(constraints):
        try:
            g = shapely.geometry.shape(c)
        except (AttributeError, KeyError, TypeError, ValueError, shapely.errors.ShapelyError):
            raise InvalidConstraint(f"constraint {i} is not a GeoJSON geometry", index=i) from None
        if g.is_empty or g.geom_type not in (
            "Point",
            "MultiPoint",
            "LineString",
            "MultiLineString",
        ):
            raise InvalidConstraint(
                f"constraint {i} must be a (Multi)Point or (Multi)LineString, not {g.geom_type}",
                index=i,
            )
        if "Line" in g.geom_type and not all(p.length > 0 for p in getattr(g, "geoms", [g])):
            raise InvalidConstraint(f"constraint {i} has a line of zero length", index=i)
        out.append(g)
    return out


def check_inside(geoms: Sequence[shapely.Geometry], region: Region) -> None:
    """Raise :class:`InvalidConstraint` naming the first of ``geoms`` that leaves ``region``
    (the union of its parts: subdomains touch)."""
    shape = shapely.union_all([p.to_shapely() for p in region.parts])  # subdomains touch
    for i, g in enumerate(geoms):
        if not shape.covers(g):
            outside = g.difference(shape)
            p = shapely.get_coordinates(outside if not outside.is_empty else g)[0]
            raise InvalidConstraint(
                f"constraint {i} leaves the region near ({p[0]:.6g}, {p[1]:.6g})",
                index=i,
                location=(float(p[0]), float(p[1])),
            )


def check_constraints(
    constraints: Sequence[Mapping[str, Any]], region: Region
) -> list[shapely.Geometry]:
    """The constraints as shapely geometries, checked as :func:`mesh_with_constraints` (and
    :func:`engine.mesh_subdomains`, ``region`` then the subdomains' parts) checks them before
    meshing (kind of geometry, no zero-length line, inside ``region``): cheap next
    to meshing, so a service can refuse bad ones at admission. Raises
    :class:`InvalidConstraint` naming the faulty one.

    >>> from engine.boundary import make_region
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> check_constraints([{"type": "Point", "coordinates": [2, 2]}], square)
    Traceback (most recent call last):
    ...
    engine.constraints.InvalidConstraint: constraint 0 leaves the region near (2, 2)
    """
    geoms = _geometries(constraints)
    check_inside(geoms, region)
    return geoms


def plain_geometries(geoms: Sequence[shapely.Geometry]) -> list[dict[str, Any]]:
    """The constraints as plain GeoJSON (lists, no tuples), as results keep them."""
    plain = [shapely.geometry.mapping(g) for g in geoms]
    listed: list[dict[str, Any]] = json.loads(json.dumps(plain))
    return listed


def _linework(region: Region) -> shapely.Geometry:
    """Every ring of ``region``'s parts (subdomains: their interfaces too), as lines."""
    return shapely.union_all([p.to_shapely().boundary for p in region.parts])


def _pieces(
    geoms: list[shapely.Geometry], region: Region, fields: Sequence[SizeField]
) -> tuple[FloatArray, IntArray, list[tuple[int, int, int]]]:
    """Constraint points (unique), the constraint of each, and the pieces (i, j, constraint) of
    lines between consecutive points: crossings with each other and with the rings of the
    region's parts (subdomain interfaces) noded, each piece split at the local size."""
    lines = [(i, g) for i, g in enumerate(geoms) if g.geom_type.endswith("LineString")]
    coords: list[FloatArray] = [np.empty((0, 2))]
    owner: list[int] = []
    chains: list[tuple[FloatArray, int]] = []
    rings = _linework(region)
    x0, y0, x1, y1 = region.bounds
    tol = 1e-9 * max(x1 - x0, y1 - y0)
    ring_xy = shapely.get_coordinates(rings)
    ring_tree = shapely.STRtree(shapely.points(ring_xy))

    def snap(xy: FloatArray) -> FloatArray:
        """``xy`` with points within ``tol`` of a ring vertex put on it: noding computes a
        crossing a rounding error away from a vertex that lies on the line."""
        got = ring_tree.query_nearest(shapely.points(xy), max_distance=tol, all_matches=False)
        out = xy.copy()
        out[got[0]] = ring_xy[got[1]]
        return out

    if lines:
        inputs = [g for _, g in lines]
        together = shapely.union_all(inputs)
        noded = shapely.node(shapely.union_all([together, rings]))
        # The inputs' segments in a tree, each knowing its line: a piece is matched to a line
        # in O(log n) per segment (distances to every line cost O(n^2): 18 s for a
        # 20,000-vertex zigzag).
        segments, line_of = _segments_of(inputs)
        tree = shapely.STRtree(segments)
        ends: list[tuple[FloatArray, FloatArray, int]] = []  # every piece's segments, in order
        for piece in getattr(noded, "geoms", [noded]):
            xy = snap(shapely.get_coordinates(piece))
            xy = xy[np.r_[True, np.any(xy[1:] != xy[:-1], axis=1)]]
            if len(xy) < 2:  # a rounding error's piece, gone once snapped
                continue
            # Every segment's midpoint, not one: a ring piece can start with a rounding
            # error's spur along a line ending a hair from the ring, or pass a line's end.
            mid = shapely.points((xy[1:] + xy[:-1]) / 2)
            found, seg = tree.query(mid, "dwithin", tol)
            # The lines with a segment near every midpoint.
            near = np.unique(np.stack([found, line_of[seg]], axis=1), axis=0)
            hit, mids = np.unique(near[:, 1], return_counts=True)
            common = hit[mids == len(mid)]
            if common.size == 0:  # a piece of ring only (or of no one line)
                continue
            i = lines[int(common.min())][0]
            ends += [(a, b, i) for a, b in itertools.pairwise(xy)]
        splits = split_segments(
            np.asarray([a for a, _, _ in ends]).reshape(-1, 2),
            np.asarray([b for _, b, _ in ends]).reshape(-1, 2),
            fields,
        )
        for (a, b, i), inner in zip(ends, splits, strict=True):
            chain = np.concatenate([a[None], inner, b[None]])
            chains.append((chain, i))
            coords.append(chain)
            owner += [i] * len(chain)
    for i, g in enumerate(geoms):
        if g.geom_type.endswith("Point"):
            xy = snap(shapely.get_coordinates(g))
            coords.append(xy)
            owner += [i] * len(xy)
    pts, inverse = np.unique(np.concatenate(coords), axis=0, return_inverse=True)
    inverse = inverse.ravel()
    which = np.full(len(pts), -1, dtype=np.int64)
    which[inverse] = owner
    if len(pts) == 0:  # every line lies on a ring: nothing to insert
        return pts, which, []
    # The smallest size along the constraints: split points are at least this far apart.
    _check_spacing(pts, which, rings, float(np.min([f(pts) for f in fields])))
    segs: list[tuple[int, int, int]] = []
    at = 0
    for chain, i in chains:
        idx = inverse[at : at + len(chain)]
        segs += [(int(a), int(b), i) for a, b in itertools.pairwise(idx.tolist())]
        at += len(chain)
    return pts, which, segs


def _segments_of(lines: list[shapely.Geometry]) -> tuple[FloatArray, IntArray]:
    """The segments of ``lines`` (as shapely lines) and the index of the line of each."""
    xy, part = shapely.get_coordinates(
        shapely.get_parts(np.asarray(lines, dtype=object)), return_index=True
    )
    owner = np.repeat(np.arange(len(lines)), [shapely.get_num_geometries(g) for g in lines])[part]
    same = part[1:] == part[:-1]
    ends = np.stack([xy[:-1][same], xy[1:][same]], axis=1)
    return shapely.linestrings(ends), owner[:-1][same]


def _check_spacing(pts: FloatArray, which: IntArray, rings: shapely.Geometry, h: float) -> None:
    """Distinct constraint points (and points and the rings) must not nearly meet."""
    near = _NEAR * h
    pair = _close_pair(pts, near)
    if pair is not None:
        k = pair[1]
        at = f"({pts[k, 0]:.6g}, {pts[k, 1]:.6g})"
        if which[pair[0]] == which[k]:  # a line's own vertices (or crossings) too close
            message = (
                f"constraint {which[k]} has points closer than {near:.3g} (5% of the size there)"
                f" at {at}: simplify it, or resample it to the size (`resample: true`, CLI "
                "--resample)"
            )
        else:
            message = f"constraint {which[k]} nearly touches another at {at}"
        raise InvalidConstraint(
            message, index=int(which[k]), location=(float(pts[k, 0]), float(pts[k, 1]))
        )
    # The nearest ring segment of each point (the distance to the rings as one geometry is
    # O(points x ring vertices)).
    segments, _ = _segments_of([rings])
    (found, _), d = shapely.STRtree(segments).query_nearest(
        shapely.points(pts), max_distance=near, return_distance=True, all_matches=False
    )
    close = found[(d > 1e-9 * h) & (d < near)]
    if close.size:
        k = int(close.min())
        raise InvalidConstraint(
            f"constraint {which[k]} nearly touches the boundary at "
            f"({pts[k, 0]:.6g}, {pts[k, 1]:.6g})",
            index=int(which[k]),
            location=(float(pts[k, 0]), float(pts[k, 1])),
        )


def _close_pair(pts: FloatArray, near: float) -> tuple[int, int] | None:
    """Two of ``pts`` (indices, the lower first) at most ``near`` apart, or None: on a grid of
    ``near / sqrt 2`` cells two points of a cell are that close, and once every cell holds one
    point only 24 neighbouring cells can hold a partner, so it costs O(n log n) however dense
    the points (every pair within ``near`` from an R-tree cost O(n^2) on a dense line: 6 s for
    a 20,000-vertex zigzag)."""
    if len(pts) < 2:
        return None
    cell = near / math.sqrt(2.0)
    ij = np.floor((pts - pts.min(axis=0)) / cell).astype(np.int64)
    order = np.lexsort((ij[:, 1], ij[:, 0]))
    ij_sorted = ij[order]
    shared = np.flatnonzero(np.all(ij_sorted[1:] == ij_sorted[:-1], axis=1))
    if shared.size:
        a, b = order[shared], order[shared + 1]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        k = int(np.lexsort((hi, lo))[0])
        return int(lo[k]), int(hi[k])
    span = int(ij[:, 1].max()) + 5
    key = ij_sorted[:, 0] * span + ij_sorted[:, 1]  # sorted, as ``order`` sorts by (i, j)
    lows, highs = [np.empty(0, dtype=np.int64)], [np.empty(0, dtype=np.int64)]
    for di in range(-2, 3):
        for dj in range(-2, 3):
            if (di, dj) <= (0, 0):  # each pair once
                continue
            want = (ij[:, 0] + di) * span + ij[:, 1] + dj
            at = np.minimum(np.searchsorted(key, want), len(key) - 1)
            hit = np.flatnonzero(key[at] == want)
            other = order[at[hit]]
            close = np.hypot(*(pts[hit] - pts[other]).T) <= near
            lows.append(np.minimum(hit[close], other[close]))
            highs.append(np.maximum(hit[close], other[close]))
    lo, hi = np.concatenate(lows), np.concatenate(highs)
    if lo.size == 0:
        return None
    k = int(np.lexsort((hi, lo))[0])
    return int(lo[k]), int(hi[k])


@dataclass(frozen=True)
class Inserted:
    """What :func:`insert_constraints` returns: the repaired mesh and what it holds."""

    mesh: Mesh
    label: IntArray  #: (m,) the region of each triangle, carried through splits and flips
    edges: IntArray  #: (k, 2) mesh edges along constraint lines
    edge_constraint: IntArray  #: (k,) the input index of each edge's constraint
    pinned: BoolArray  #: (n,) constraint nodes


def insert_constraints(
    mesh: Mesh,
    region: Region,
    geoms: Sequence[shapely.Geometry],
    fields: Sequence[SizeField],
    label: IntArray | None = None,
    held: BoolArray | None = None,
    should_stop: StopFn | None = None,
) -> Inserted:
    """Put checked constraints (:func:`check_constraints`) into ``mesh`` of ``region`` by local
    repair: lines noded with each other and with the rings of ``region``'s parts (subdomain
    interfaces), split at the smallest of ``fields``, points made nodes, pieces recovered by
    flips. ``label`` (each triangle's region) is carried; no flip crosses a change of label and
    no ``held`` node is moved. Polls ``should_stop`` between pieces."""
    label = np.ones(mesh.n_triangles, dtype=np.int64) if label is None else label
    held = np.zeros(mesh.n_points, dtype=bool) if held is None else held
    pts, _, segs = _pieces(list(geoms), region, fields)
    work = Repair(
        mesh.points.copy(), mesh.triangles.copy(), np.zeros(mesh.n_points, bool), 0.0,
        label.copy(), held.copy(),
    )  # fmt: skip
    sizes = np.min([f(pts) for f in fields], axis=0)
    index = []
    for q, h in zip(pts, sizes, strict=True):
        work.h = float(h)
        index.append(work.node(q))
    edges: list[tuple[int, int]] = []
    owner: list[int] = []
    for a, b, i in segs:
        if should_stop is not None and should_stop():
            raise Cancelled("stopped while putting in the constraints")
        work.h = float(sizes[a])
        chain = work.recover(index[a], index[b])
        edges += chain
        owner += [i] * len(chain)
    return Inserted(
        Mesh(work.pts, work.tris), work.label, np.asarray(edges, dtype=np.int64).reshape(-1, 2),
        np.asarray(owner, dtype=np.int64), work.pinned,
    )  # fmt: skip


def mesh_with_constraints(
    region: Region,
    params: PipelineParams,
    constraints: Sequence[Mapping[str, Any]],
    rng: np.random.Generator | None = None,
    progress: ProgressFn | None = None,
    should_stop: StopFn | None = None,
    keep: ArrayLike = (),
) -> Constrained:
    """Mesh ``region`` with ``constraints`` (GeoJSON (Multi)Point and (Multi)LineString
    geometries) as mesh nodes and chains of mesh edges; swap and smooth holding them.
    Reports ``progress`` and polls ``should_stop`` as :func:`engine.mesh_then_smooth` does.
    With ``sizing.resample`` the rings and the constraint lines are resampled together
    (:func:`engine.resample.resample_constraints`; ``keep``: more ring vertices to keep, such
    as the ends of named runs) and the summary's ``boundary`` reports both deviations.

    >>> from engine.boundary import make_region
    >>> from engine.params import SizingParams, SmoothingParams
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> line = {"type": "LineString", "coordinates": [[0.2, 0.3], [0.8, 0.6]]}
    >>> params = PipelineParams(SizingParams(0.1), smoothing=SmoothingParams("laplacian"))
    >>> out = mesh_with_constraints(square, params, [line])
    >>> out.result.smoothed.summary["inverted"], len(out.edges) > 5
    (0, True)
    """
    rng = rng if rng is not None else np.random.default_rng(0)
    started = time.perf_counter()
    geoms = check_constraints(constraints, region)
    if progress is not None:
        progress("boundary", 0.0)
    boundary, sizing = None, params.sizing
    if sizing.resample:
        boundary, geoms, deviation = resample_constraints(region, sizing, geoms, keep)
        region, sizing = boundary.region, replace(sizing, resample=False)
        check_inside(geoms, region)
    field = build_size_field(region, sizing)
    resampled = time.perf_counter() - started
    mesh, timings = mesh_region(
        region, sizing, params.relax, should_stop, params.max_triangles, progress
    )
    t = time.perf_counter()
    got = insert_constraints(mesh, region, geoms, [field], should_stop=should_stop)
    if progress is not None:
        progress("mesh", 1.0)
    # Checking, resampling and the field count with the boundary, insertion with the mesh.
    timings["boundary"] += resampled
    timings["mesh"] += time.perf_counter() - t
    result = improve_held(
        got.mesh, got.edges, got.pinned, params, rng, progress, should_stop, timings, started
    )
    result.parameters["constraints"] = plain_geometries(geoms)
    if boundary is not None:
        summary = {**boundary.summary(), "constraints_max_deviation": deviation}
        result.smoothed.summary["boundary"] = summary
    return Constrained(
        result=result,
        edges=got.edges,
        edge_constraint=got.edge_constraint,
        nodes=np.flatnonzero(got.pinned).astype(np.int64),
        region=region,
        boundary=boundary,
    )


def improve_held(
    mesh: Mesh,
    locked: IntArray,
    pinned: BoolArray,
    params: PipelineParams,
    rng: np.random.Generator,
    progress: ProgressFn | None = None,
    should_stop: StopFn | None = None,
    timings: Mapping[str, float] | None = None,
    started: float | None = None,
) -> Result:
    """Swap and smooth ``mesh`` as :func:`engine.mesh_then_smooth` does (diagonal swapping,
    valence regularisation, smoothing) with the ``locked`` edges never flipped and the
    ``pinned`` nodes held (as boundary nodes); its ``progress`` stages ``swap`` and ``smooth``,
    polling ``should_stop`` between them. ``timings`` (the meshing stages') gain ``swap``,
    ``smooth`` and ``total`` (since ``started``, by default now)."""
    return improve_mesh(
        PinnedMesh(mesh.points, mesh.triangles, pinned), params.smoothing, params.swap, rng,
        progress or _quiet, should_stop or _never,
        {"boundary": 0.0, "mesh": 0.0, **(timings or {})}, params.to_dict(),
        time.perf_counter() if started is None else started, locked=locked,
    )  # fmt: skip


def _quiet(stage: str, fraction: float) -> None:
    del stage, fraction


def _never() -> bool:
    return False
