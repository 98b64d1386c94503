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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
import shapely.geometry
from numpy.typing import NDArray

from .boundary import Region
from .errors import EngineError, MeshingError
from .mesh import Mesh, edge_table
from .params import PipelineParams
from .pipeline import mesh_region
from .result import Result
from .sizing import build_size_field
from .subdomains import improve_held, split_segment

__all__ = ["Constrained", "InvalidConstraint", "check_constraints", "mesh_with_constraints"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

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
class Constrained:
    """What :func:`mesh_with_constraints` returns."""

    result: Result
    edges: IntArray  #: (k, 2) mesh edges along constraint lines
    edge_constraint: IntArray  #: (k,) the input index of each edge's constraint
    nodes: IntArray  #: mesh nodes of every constraint (points, line vertices and splits)

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


def _check_inside(geoms: list[shapely.Geometry], region: Region) -> None:
    shape = region.to_shapely()
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
    """The constraints as shapely geometries, checked as :func:`mesh_with_constraints` checks
    them before meshing (kind of geometry, no zero-length line, inside ``region``): cheap next
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
    _check_inside(geoms, region)
    return geoms


def _pieces(
    geoms: list[shapely.Geometry], region: Region, fields: Any
) -> tuple[FloatArray, IntArray, list[tuple[int, int, int]]]:
    """Constraint points (unique), the constraint of each, and the pieces (i, j, constraint) of
    lines between consecutive points: crossings noded, each piece split at the local size."""
    lines = [(i, g) for i, g in enumerate(geoms) if g.geom_type.endswith("LineString")]
    coords: list[FloatArray] = [np.empty((0, 2))]
    owner: list[int] = []
    chains: list[tuple[FloatArray, int]] = []
    if lines:
        noded = shapely.node(shapely.union_all([g for _, g in lines]))
        inputs = [g for _, g in lines]
        for piece in getattr(noded, "geoms", [noded]):
            xy = shapely.get_coordinates(piece)
            mid = shapely.Point((xy[0] + xy[1]) / 2)
            i = lines[int(np.argmin([g.distance(mid) for g in inputs]))][0]
            for a, b in itertools.pairwise(xy):
                chain = np.concatenate([a[None], split_segment(a, b, fields), b[None]])
                chains.append((chain, i))
                coords.append(chain)
                owner += [i] * len(chain)
    for i, g in enumerate(geoms):
        if g.geom_type.endswith("Point"):
            xy = shapely.get_coordinates(g)
            coords.append(xy)
            owner += [i] * len(xy)
    pts, inverse = np.unique(np.concatenate(coords), axis=0, return_inverse=True)
    inverse = inverse.ravel()
    which = np.full(len(pts), -1, dtype=np.int64)
    which[inverse] = owner
    # The smallest size along the constraints: split points are at least this far apart.
    _check_spacing(pts, which, region, float(np.min([f(pts) for f in fields])))
    segs: list[tuple[int, int, int]] = []
    at = 0
    for chain, i in chains:
        idx = inverse[at : at + len(chain)]
        segs += [(int(a), int(b), i) for a, b in itertools.pairwise(idx.tolist())]
        at += len(chain)
    return pts, which, segs


def _check_spacing(pts: FloatArray, which: IntArray, region: Region, h: float) -> None:
    """Distinct constraint points (and points and the boundary) must not nearly meet."""
    near = _NEAR * h
    tree = shapely.STRtree(shapely.points(pts))
    a, b = tree.query(shapely.points(pts), "dwithin", near)
    bad = a < b
    if bad.any():
        k = int(b[bad][0])
        raise InvalidConstraint(
            f"constraint {which[k]} nearly touches another at ({pts[k, 0]:.6g}, {pts[k, 1]:.6g})",
            index=int(which[k]),
            location=(float(pts[k, 0]), float(pts[k, 1])),
        )
    edge = region.to_shapely().boundary
    d = shapely.distance(edge, shapely.points(pts))
    close = np.flatnonzero((d > 1e-9 * h) & (d < near))
    if close.size:
        k = int(close[0])
        raise InvalidConstraint(
            f"constraint {which[k]} nearly touches the boundary at "
            f"({pts[k, 0]:.6g}, {pts[k, 1]:.6g})",
            index=int(which[k]),
            location=(float(pts[k, 0]), float(pts[k, 1])),
        )


def _barycentric(pts: FloatArray, tris: IntArray, q: FloatArray) -> FloatArray:
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    l1 = ((b[:, 0] - q[0]) * (c[:, 1] - q[1]) - (b[:, 1] - q[1]) * (c[:, 0] - q[0])) / det
    l2 = ((c[:, 0] - q[0]) * (a[:, 1] - q[1]) - (c[:, 1] - q[1]) * (a[:, 0] - q[0])) / det
    return np.stack([l1, l2, 1.0 - l1 - l2], axis=1)


def _area(p: FloatArray, t: IntArray) -> FloatArray:
    return Mesh(p, t).areas


@dataclass
class _Repair:
    """A mesh being repaired in place: points, triangles and nodes no step may move."""

    pts: FloatArray
    tris: IntArray
    pinned: NDArray[np.bool_]
    h: float

    def node(self, q: FloatArray) -> int:
        """The node at ``q``: an existing one, a free interior one moved there, or a new one."""
        d = np.hypot(*(self.pts - q).T)
        n = int(np.argmin(d))
        if d[n] <= 1e-9 * self.h:
            self.pinned[n] = True
            return n
        boundary = Mesh(self.pts, self.tris).boundary_nodes
        order = np.argsort(d)[:4]
        for n in order.tolist():
            if d[n] > 0.45 * self.h or boundary[n] or self.pinned[n]:
                continue
            around = np.flatnonzero((self.tris == n).any(axis=1))
            moved = self.pts.copy()
            moved[n] = q
            before = _area(self.pts, self.tris[around])
            if np.all(_area(moved, self.tris[around]) > 0.05 * before.max()):
                self.pts = moved
                self.pinned[n] = True
                return n
        return self._insert(q)

    def _insert(self, q: FloatArray) -> int:
        lam = _barycentric(self.pts, self.tris, q)
        inside = np.flatnonzero((lam >= -1e-12).all(axis=1))
        if not inside.size:
            raise MeshingError(f"no triangle holds ({q[0]:.6g}, {q[1]:.6g})")
        t = int(inside[0])
        n = len(self.pts)
        self.pts = np.vstack([self.pts, q])
        self.pinned = np.append(self.pinned, True)
        i, j, k = self.tris[t].tolist()
        small = np.flatnonzero(np.abs(lam[t]) < 1e-9)
        if small.size:  # on the side opposite that corner: split it and its neighbour
            corner = int(small[0])
            u, v, w = np.roll(self.tris[t], -corner).tolist()  # side v-w, opposite u
            keep = [x for x in range(len(self.tris)) if x != t]
            new = [[u, v, n], [u, n, w]]
            other = np.flatnonzero(((self.tris == v).any(axis=1)) & ((self.tris == w).any(axis=1)))
            other = other[other != t]
            if other.size:
                o = int(other[0])
                x = int(next(z for z in self.tris[o].tolist() if z not in (v, w)))
                keep = [y for y in keep if y != o]
                new += [[x, w, n], [x, n, v]]
            self.tris = np.vstack([self.tris[keep], np.asarray(new, dtype=np.int64)])
        else:
            rest = np.delete(self.tris, t, axis=0)
            new3 = np.asarray([[i, j, n], [j, k, n], [k, i, n]], dtype=np.int64)
            self.tris = np.vstack([rest, new3])
        return n

    def recover(self, a: int, b: int) -> list[tuple[int, int]]:
        """Make ``a-b`` a chain of mesh edges by flipping; the edges of the chain."""
        for _ in range(10_000):
            edges, _, _ = edge_table(self.tris)
            lo, hi = min(a, b), max(a, b)
            if np.any((edges[:, 0] == lo) & (edges[:, 1] == hi)):
                return [(a, b)]
            pa, pb = self.pts[a], self.pts[b]
            # A node on the open segment splits it.
            d = pb - pa
            t = ((self.pts - pa) @ d) / (d @ d)
            off = np.abs((self.pts[:, 0] - pa[0]) * d[1] - (self.pts[:, 1] - pa[1]) * d[0])
            on = np.flatnonzero((t > 1e-9) & (t < 1 - 1e-9) & (off < 1e-9 * (d @ d)))
            if on.size:
                c = int(on[np.argmin(t[on])])
                self.pinned[c] = True
                return self.recover(a, c) + self.recover(c, b)
            crossing = self._crossing(edges, a, b)
            if not any(self._flip(int(u), int(v)) for u, v in crossing):
                raise MeshingError(f"cannot recover the constraint edge from node {a} to {b}")
        raise MeshingError(f"cannot recover the constraint edge from node {a} to {b}")

    def _crossing(self, edges: IntArray, a: int, b: int) -> IntArray:
        p, pa, pb = self.pts, self.pts[a], self.pts[b]

        def side(o: FloatArray, x: FloatArray, y: FloatArray) -> FloatArray:
            return np.sign((x[..., 0] - o[..., 0]) * (y[..., 1] - o[..., 1])
                           - (x[..., 1] - o[..., 1]) * (y[..., 0] - o[..., 0]))  # fmt: skip

        u, v = p[edges[:, 0]], p[edges[:, 1]]
        s1, s2 = side(pa, pb, u), side(pa, pb, v)
        s3, s4 = side(u, v, np.broadcast_to(pa, u.shape)), side(u, v, np.broadcast_to(pb, u.shape))
        hit = (s1 * s2 < 0) & (s3 * s4 < 0)
        return edges[hit]

    def _flip(self, u: int, v: int) -> bool:
        both = np.flatnonzero((self.tris == u).any(axis=1) & (self.tris == v).any(axis=1))
        if len(both) != 2:
            return False
        t1, t2 = (int(x) for x in both)
        w1 = int(next(z for z in self.tris[t1].tolist() if z not in (u, v)))
        w2 = int(next(z for z in self.tris[t2].tolist() if z not in (u, v)))
        new = np.asarray([[w1, w2, u], [w2, w1, v]], dtype=np.int64)
        area = _area(self.pts, new)
        if np.any(area < 0):
            new = new[:, [0, 2, 1]]
            area = -area
        if np.any(area <= 1e-12 * self.h * self.h):
            return False  # not a convex quadrilateral
        # Both new triangles counter-clockwise and covering the same quadrilateral.
        if abs(area.sum() - np.abs(_area(self.pts, self.tris[[t1, t2]])).sum()) > 1e-9 * area.sum():
            return False
        self.tris[[t1, t2]] = new
        return True


def mesh_with_constraints(
    region: Region,
    params: PipelineParams,
    constraints: Sequence[Mapping[str, Any]],
    rng: np.random.Generator | None = None,
) -> Constrained:
    """Mesh ``region`` with ``constraints`` (GeoJSON (Multi)Point and (Multi)LineString
    geometries) as mesh nodes and chains of mesh edges; swap and smooth holding them.

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
    geoms = check_constraints(constraints, region)
    field = build_size_field(region, params.sizing)
    mesh, _ = mesh_region(region, params.sizing, params.relax, max_triangles=params.max_triangles)
    pts, _, segs = _pieces(geoms, region, [field])
    work = _Repair(mesh.points.copy(), mesh.triangles.copy(), np.zeros(mesh.n_points, bool), 0.0)
    sizes = field(pts)
    index = []
    for q, h in zip(pts, sizes, strict=True):
        work.h = float(h)
        index.append(work.node(q))
    edges: list[tuple[int, int]] = []
    owner: list[int] = []
    for a, b, i in segs:
        work.h = float(sizes[a])
        chain = work.recover(index[a], index[b])
        edges += chain
        owner += [i] * len(chain)
    locked = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    fixed = Mesh(work.pts, work.tris)
    result = improve_held(fixed, locked, work.pinned, params, rng)
    return Constrained(
        result=result,
        edges=locked,
        edge_constraint=np.asarray(owner, dtype=np.int64),
        nodes=np.flatnonzero(work.pinned).astype(np.int64),
    )
