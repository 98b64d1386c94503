"""The triangle mesh: a frozen pair of arrays, its edges and its boundary, and input checks."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Self, TypeVar

import numba
import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from .errors import InvalidMesh

__all__ = [
    "Mesh",
    "corner_order",
    "edge_table",
    "keeps_boundary",
    "triangle_areas",
    "validate_mesh",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]
MeshT = TypeVar("MeshT", bound="Mesh")


def triangle_areas(points: FloatArray, triangles: IntArray) -> FloatArray:
    """Signed areas of ``triangles`` (positive when counter-clockwise).

    >>> pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> float(triangle_areas(pts, np.array([[0, 1, 2]]))[0])
    0.5
    """
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return 0.5 * (
        (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    )


def edge_table(triangles: IntArray) -> tuple[IntArray, IntArray, IntArray]:
    """Undirected edges of ``triangles``.

    Returns ``(edges, count, edge_of)``: ``edges`` (e, 2) sorted vertex pairs, ``count`` (e,) the
    number of triangles holding each edge, ``edge_of`` (m, 3) the edge index of the side opposite
    each corner (side k joins corners k+1 and k+2).
    """
    tri = np.ascontiguousarray(triangles, dtype=np.int64)
    if len(tri) == 0:
        empty = np.zeros((0, 2), dtype=np.int64)
        return empty, np.zeros(0, dtype=np.int64), np.zeros((0, 3), dtype=np.int64)
    return _edge_table(tri, corner_order(tri))


@numba.njit(cache=True)
def _edge_table(
    tri: IntArray, order: IntArray
) -> tuple[IntArray, IntArray, IntArray]:  # pragma: no cover - compiled
    """:func:`edge_table` from the stars (``order``: :func:`corner_order`) rather than a sort
    of every side: node by node, the sides whose smaller node it is, by their larger node, so
    the edges come out sorted as the sort gave them."""
    m = len(tri)
    n = np.int64(0)
    for i in range(m):
        for k in range(3):
            n = max(n, tri[i, k] + 1)
    start = np.zeros(n + 1, dtype=np.int64)
    for i in range(m):
        for k in range(3):
            start[tri[i, k] + 1] += 1
    most = 0
    for v in range(n):
        most = max(most, start[v + 1])
        start[v + 1] += start[v]
    edges = np.empty((3 * m, 2), dtype=np.int64)
    count = np.empty(3 * m, dtype=np.int64)
    edge_of = np.empty((m, 3), dtype=np.int64)
    his = np.empty(3 * most, dtype=np.int64)
    keys = np.empty(3 * most, dtype=np.int64)
    e = 0
    for v in range(n):
        size = 0
        last = -1
        for s in range(start[v], start[v + 1]):
            t = order[s] // 3
            if t == last:  # a repeated corner lists a triangle twice
                continue
            last = t
            for k in range(3):
                c, d = tri[t, (k + 1) % 3], tri[t, (k + 2) % 3]
                if min(c, d) != v:
                    continue
                # Insertion by larger node, then by side: the sides of one edge stay together.
                hi, key, j = max(c, d), 3 * t + k, size
                while j > 0 and his[j - 1] > hi:
                    his[j], keys[j] = his[j - 1], keys[j - 1]
                    j -= 1
                his[j], keys[j] = hi, key
                size += 1
        for j in range(size):
            if j == 0 or his[j] != his[j - 1]:
                edges[e, 0], edges[e, 1], count[e] = v, his[j], 0
                e += 1
            count[e - 1] += 1
            edge_of[keys[j] // 3, keys[j] % 3] = e - 1
    return edges[:e].copy(), count[:e].copy(), edge_of


def _edge_codes(sides: IntArray) -> IntArray:
    """One integer per undirected edge (sorting rows is several times slower)."""
    lo = np.minimum(sides[:, 0], sides[:, 1]).astype(np.int64)
    hi = np.maximum(sides[:, 0], sides[:, 1]).astype(np.int64)
    n = np.int64(hi.max()) + 1 if len(hi) else np.int64(1)
    return lo * n + hi


def corner_order(corners: IntArray) -> IntArray:
    """``np.argsort(corners.ravel(), kind="stable")`` of node numbers (non-negative) by a
    counting sort, several times faster: the order of the stars of all nodes.

    >>> corner_order(np.array([[2, 0, 1], [0, 3, 2]])).tolist()
    [1, 3, 2, 0, 5, 4]
    """
    flat = np.ascontiguousarray(corners, dtype=np.int64).ravel()
    counts = np.bincount(flat)
    starts = np.zeros(len(counts), dtype=np.int64)
    np.cumsum(counts[:-1], out=starts[1:])
    return _counting_order(flat, starts)


@numba.njit(cache=True)
def _counting_order(flat: IntArray, starts: IntArray) -> IntArray:  # pragma: no cover
    fill = starts.copy()
    order = np.empty(len(flat), dtype=np.int64)
    for i in range(len(flat)):
        order[fill[flat[i]]] = i
        fill[flat[i]] += 1
    return order


@dataclass(frozen=True)
class Mesh:
    """A planar triangle mesh.

    >>> m = Mesh(np.array([[0.0, 0], [1, 0], [0, 1]]), np.array([[0, 1, 2]]))
    >>> m.boundary_nodes.tolist()
    [True, True, True]
    """

    points: FloatArray  #: (n, 2) vertex coordinates
    triangles: IntArray  #: (m, 3) vertex indices, counter-clockwise, 0-based

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_triangles(self) -> int:
        return int(self.triangles.shape[0])

    @cached_property
    def areas(self) -> FloatArray:
        """Signed triangle areas."""
        return triangle_areas(self.points, self.triangles)

    @cached_property
    def boundary_edges(self) -> IntArray:
        """Directed boundary edges (e, 2), oriented with the mesh on their left."""
        sides = np.stack(
            [self.triangles[:, [0, 1]], self.triangles[:, [1, 2]], self.triangles[:, [2, 0]]],
            axis=1,
        ).reshape(-1, 2)
        codes = _edge_codes(sides)
        order = np.argsort(codes, kind="stable")
        sorted_codes = codes[order]
        lonely = np.ones(len(codes), dtype=bool)
        same = sorted_codes[1:] == sorted_codes[:-1]
        lonely[1:] &= ~same
        lonely[:-1] &= ~same
        return sides[np.sort(order[lonely])]

    @cached_property
    def boundary_nodes(self) -> BoolArray:
        """True for vertices on the boundary, and for vertices used by no triangle."""
        mask = np.ones(self.n_points, dtype=bool)
        mask[self.triangles.ravel()] = False
        mask[self.boundary_edges.ravel()] = True
        return mask

    def with_points(self, points: FloatArray) -> Self:
        """The same connectivity with moved vertices, of the same class (a subclass keeps its
        own fields: a :class:`~engine.constraints.PinnedMesh` its pins), and so the same
        boundary edges: when already found they carry over rather than being searched again."""
        moved = replace(self, points=points)
        if "boundary_edges" in self.__dict__:  # a cached_property's value lives there
            moved.__dict__["boundary_edges"] = self.__dict__["boundary_edges"]
        return moved


def keeps_boundary(mesh: MeshT, source: Mesh) -> MeshT:
    """``mesh``, made from ``source`` by moving interior nodes and flipping interior edges
    (which keep every boundary node one, and every other node not), told that its boundary
    nodes are ``source``'s so that they are not searched for again; ``mesh`` as it is when its
    class differs (a subclass may count other nodes as boundary)."""
    if type(mesh) is type(source):
        mesh.__dict__["boundary_nodes"] = source.boundary_nodes
    return mesh


def _whole_numbers(values: NDArray[np.generic]) -> bool:
    try:
        as_float = values.astype(np.float64)
    except (TypeError, ValueError):
        return False
    return bool(np.all(np.isfinite(as_float)) and np.all(as_float % 1 == 0))


def validate_mesh(points: ArrayLike, triangles: ArrayLike, *, area_tol: float = 0.0) -> Mesh:
    """Check an input mesh and return it as a :class:`Mesh`.

    Raises :class:`InvalidMesh` naming the first offending element when the arrays have the wrong
    shape, hold NaN/inf, index out of range, repeat a vertex in a triangle, hold an inverted or
    degenerate triangle, share an edge between more than two triangles (or two with the same
    orientation), fold over an interior vertex, or overlap along its boundary (two boundary
    edges meeting other than at a shared end: a triangle laid over others).

    >>> validate_mesh([[0, 0], [1, 0], [0, 1]], [[0, 2, 1]])
    Traceback (most recent call last):
    ...
    engine.errors.InvalidMesh: triangle 0 is inverted or degenerate (signed area -0.5)
    """
    try:
        pts = np.asarray(points, dtype=np.float64)
        tri_in = np.asarray(triangles)
    except (TypeError, ValueError) as exc:
        raise InvalidMesh(f"points and triangles must be numeric arrays: {exc}") from None
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 3:
        raise InvalidMesh(
            f"points must be a list of at least 3 [x, y] pairs, got shape {pts.shape}"
        )
    if tri_in.ndim != 2 or tri_in.shape[1] != 3 or len(tri_in) < 1:
        raise InvalidMesh(
            f"triangles must be a list of [i, j, k] triples, got shape {tri_in.shape}"
        )
    bad = np.flatnonzero(~np.isfinite(pts).all(axis=1))
    if bad.size:
        raise InvalidMesh(f"point {bad[0]} has a non-finite coordinate", point=int(bad[0]))
    if not np.issubdtype(tri_in.dtype, np.integer) and not _whole_numbers(tri_in):
        raise InvalidMesh("triangle indices must be integers")
    tri = tri_in.astype(np.int64)
    out = np.flatnonzero(((tri < 0) | (tri >= len(pts))).any(axis=1))
    if out.size:
        raise InvalidMesh(
            f"triangle {out[0]} refers to a point outside 0..{len(pts) - 1}", triangle=int(out[0])
        )
    rep = np.flatnonzero(
        (tri[:, 0] == tri[:, 1]) | (tri[:, 1] == tri[:, 2]) | (tri[:, 0] == tri[:, 2])
    )
    if rep.size:
        raise InvalidMesh(f"triangle {rep[0]} repeats a vertex", triangle=int(rep[0]))
    areas = triangle_areas(pts, tri)
    # Degenerate relative to the triangle's own size: the sign of a small triangle's area is
    # exact to about eps * (its longest side)^2, whatever the mesh's extent, so a graded mesh
    # may hold triangles far smaller than its extent.
    p = pts[tri]
    longest2 = np.max(np.sum((p - np.roll(p, 1, axis=1)) ** 2, axis=2), axis=1)
    flat = np.flatnonzero((areas <= area_tol) | (areas <= 1e-12 * longest2))
    if flat.size:
        t = int(flat[0])
        raise InvalidMesh(
            f"triangle {t} is inverted or degenerate (signed area {areas[t]:.3g})", triangle=t
        )
    edges, count, edge_of = edge_table(tri)
    over = np.flatnonzero(count > 2)
    if over.size:
        e = edges[over[0]]
        t = int(np.flatnonzero((edge_of == over[0]).any(axis=1))[0])
        raise InvalidMesh(
            f"edge ({e[0]}, {e[1]}) is shared by more than two triangles (non-manifold)",
            triangle=t,
        )
    # Two triangles sharing an edge must traverse it in opposite directions.
    directed = np.stack([tri[:, [1, 2]], tri[:, [2, 0]], tri[:, [0, 1]]], axis=1).reshape(-1, 2)
    key = np.sort(directed[:, 0] * len(pts) + directed[:, 1])  # one int per directed edge
    if np.any(key[1:] == key[:-1]):
        raise InvalidMesh("two triangles traverse the same edge in the same direction")
    mesh = Mesh(pts, tri)
    _check_no_fold(mesh)
    _check_boundary_simple(mesh)
    return mesh


def _check_no_fold(mesh: Mesh) -> None:
    """Interior vertices must see exactly one full turn of triangle corners (no overlap)."""
    p, t = mesh.points, mesh.triangles
    angle_sum = np.zeros(mesh.n_points)
    for k in range(3):
        a, b, c = p[t[:, k]], p[t[:, (k + 1) % 3]], p[t[:, (k + 2) % 3]]
        u, v = b - a, c - a
        ang = np.arctan2(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0], (u * v).sum(axis=1))
        angle_sum += np.bincount(t[:, k], weights=ang, minlength=mesh.n_points)
    interior = ~mesh.boundary_nodes
    folded = np.flatnonzero(interior & (np.abs(angle_sum - 2 * np.pi) > 1e-6))
    if folded.size:
        node = int(folded[0])
        raise InvalidMesh(
            f"the triangles around point {node} overlap (corner angles sum to "
            f"{np.degrees(angle_sum[node]):.1f} degrees, not 360)",
            point=node,
        )


def _check_boundary_simple(mesh: Mesh) -> None:
    """No two boundary edges cross, nor run along each other in the same direction, and no
    piece of the mesh lies inside another: with no fold at an interior vertex
    (:func:`_check_no_fold`) and counter-clockwise triangles, that is where triangles laid over
    others show (a triangle spanning a grid's corners: its edges, all on the boundary, run along
    the grid's bottom and cross its inside). Pieces that abut (their boundary edges along each
    other in opposite directions, matching or not) or touch at a point are fine. O(n log n)
    through R-trees of the boundary edges and of the triangles."""
    edges = mesh.boundary_edges
    if len(edges) < 2:
        return
    p = mesh.points
    a0, a1 = p[edges[:, 0]], p[edges[:, 1]]
    segments = shapely.linestrings(np.stack([a0, a1], axis=1))
    i, j = shapely.STRtree(segments).query(segments, "intersects")
    i, j = i[i < j], j[i < j]
    u, v = a1[i] - a0[i], a1[j] - a0[j]
    scale = np.hypot(*u.T) * np.hypot(*v.T)

    def side(o: FloatArray, d: FloatArray, q: FloatArray) -> FloatArray:
        """Which side of the line o + t d the points q are (0 within rounding)."""
        cross = d[:, 0] * (q[:, 1] - o[:, 1]) - d[:, 1] * (q[:, 0] - o[:, 0])
        return np.where(np.abs(cross) <= 1e-12 * scale, 0.0, np.sign(cross))

    s1, s2 = side(a0[i], u, a0[j]), side(a0[i], u, a1[j])
    s3, s4 = side(a0[j], v, a0[i]), side(a0[j], v, a1[i])
    crossing = (s1 * s2 < 0) & (s3 * s4 < 0)
    # Collinear: the overlap of their spans along the first, in the same direction.
    collinear = (s1 == 0) & (s2 == 0)
    length = np.hypot(*u.T)
    along = (
        np.stack([((a0[j] - a0[i]) * u).sum(1), ((a1[j] - a0[i]) * u).sum(1)], 1) / length[:, None]
    )
    overlap = np.minimum(length, along.max(1)) - np.maximum(0.0, along.min(1))
    same_way = (u * v).sum(1) > 0
    bad = np.flatnonzero(crossing | (collinear & same_way & (overlap > 1e-9 * length)))
    if bad.size:
        e = edges[int(i[bad[0]])]
        raise InvalidMesh(
            f"boundary edge ({e[0]}, {e[1]}) crosses or runs along another: triangles overlap",
            point=int(e[0]),
        )
    _check_pieces_apart(mesh)


def _check_pieces_apart(mesh: Mesh) -> None:
    """No piece of the mesh (triangles joined by edges) lies inside another's triangles."""
    label = _pieces(mesh)
    if label.max(initial=0) == 0:
        return
    first = np.unique(label, return_index=True)[1]
    # One node of each piece, and a point just inside its first triangle (a node of a piece
    # abutting another lies on that one's boundary).
    tri = mesh.triangles[first]
    probe = shapely.points(mesh.points[tri].mean(axis=1))
    triangles = shapely.polygons(mesh.points[mesh.triangles])
    k, t = shapely.STRtree(triangles).query(probe, "within")
    inside = np.flatnonzero(label[t] != label[first[k]])
    if inside.size:
        node = int(mesh.triangles[first[k[inside[0]]], 0])
        raise InvalidMesh(
            f"a piece of the mesh (with point {node}) lies over another piece's triangles",
            point=node,
        )


def _pieces(mesh: Mesh) -> IntArray:
    """A label per triangle: the piece (triangles joined by shared edges) it belongs to."""
    _, _, edge_of = edge_table(mesh.triangles)
    flat = edge_of.ravel()
    order = np.argsort(flat, kind="stable")
    twin = np.flatnonzero(flat[order[:-1]] == flat[order[1:]])
    return _union_find(order[twin] // 3, order[twin + 1] // 3, mesh.n_triangles)


@numba.njit(cache=True)
def _union_find(a: IntArray, b: IntArray, n: int) -> IntArray:  # pragma: no cover - compiled
    """Labels 0.. of the classes of ``n`` items joined by the pairs (a[k], b[k])."""
    parent = np.arange(n)
    for k in range(len(a)):
        x, y = a[k], b[k]
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        while parent[y] != y:
            parent[y] = parent[parent[y]]
            y = parent[y]
        if x != y:
            parent[max(x, y)] = min(x, y)
    label = np.empty(n, dtype=np.int64)
    count = 0
    for x in range(n):
        root = x
        while parent[root] != root:
            root = parent[root]
        if root == x:
            label[x] = count
            count += 1
        else:
            label[x] = label[root]
    return label
