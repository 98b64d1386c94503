"""Edge collapse: merge the two nodes of an interior edge where that lifts the worst triangle.

Where advancing fronts meet they can leave a node too many: a short edge between two nodes with
four and eight neighbours, say. No edge flip changes the node count and no node movement fixes
it, so the worst triangle there stays well below the rest. Collapsing the edge repairs it: its two
triangles vanish and its two nodes become one, placed where the worst triangle around it is best
(a boundary node stays where it is; an edge between two boundary nodes never collapses). A
collapse is kept only when that worst triangle is better than the worst around the two nodes
before, and only when the two nodes share exactly two neighbours (so the mesh stays a manifold).

Each round evaluates the edges around bad triangles, then applies the best collapses whose
neighbourhoods do not overlap, all at once (O(n) per round). The boundary never changes.

>>> import numpy as np
>>> from engine.mesh import Mesh
>>> ring = [[np.cos(a), np.sin(a)] for a in np.linspace(0, 2 * np.pi, 7)[:-1]]
>>> pts = np.array(ring + [[-0.05, 0.0], [0.05, 0.0]])  # two nodes where one belongs
>>> tris = [[6, 1, 2], [6, 2, 3], [6, 3, 4], [6, 4, 7], [7, 4, 5], [7, 5, 0], [7, 0, 1], [7, 1, 6]]
>>> out = collapse_edges(Mesh(pts, np.array(tris)))
>>> out.n_points, out.n_triangles, bool(np.abs(out.points[6]).max() < 1e-6)
(7, 6, True)
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from .errors import Cancelled
from .fitness import star_min
from .mesh import Mesh, edge_table
from .quality import shape_quality, shape_quality_xy
from .relax import node_stars
from .result import StopFn

__all__ = ["collapse_edges"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Edges are looked at when a triangle around either node is below this quality.
COLLAPSE_BELOW = 0.95
#: A collapse must lift the worst quality around the edge by this much.
GAIN = 1e-3
ROUNDS = 4
_COMPASS_ITERATIONS = 10
#: Edges whose best start (an end or the midpoint) is this far below the worst quality around
#: them now are not searched further: the compass search never gained that much where measured.
_HOPELESS = 0.3
#: The compass directions (the values ``math.cos(d * pi / 4)`` and ``math.sin`` give).
_DX = np.array([math.cos(d * math.pi / 4.0) for d in range(8)])
_DY = np.array([math.sin(d * math.pi / 4.0) for d in range(8)])


@nb.njit(cache=True)
def _gather(
    p: FloatArray,
    t: IntArray,
    start: IntArray,
    tri_of: IntArray,
    a: int,
    b: int,
    xy: FloatArray,
    mover: IntArray,
) -> int:  # pragma: no cover - compiled
    """Corners (rows of ``xy``: x0, y0, x1, y1, x2, y2) of the triangles around a and b that
    outlive their collapse, and which corner (``mover``) is the merged node; returns their
    count. Gathered once per edge, as every trial position of the merged node reads them."""
    count = 0
    for v in (a, b):
        for k in range(start[v], start[v + 1]):
            tr = tri_of[k]
            has_a = t[tr, 0] == a or t[tr, 1] == a or t[tr, 2] == a
            has_b = t[tr, 0] == b or t[tr, 1] == b or t[tr, 2] == b
            if has_a and has_b:
                continue  # the edge's own triangles vanish
            for j in range(3):
                xy[count, 2 * j], xy[count, 2 * j + 1] = p[t[tr, j], 0], p[t[tr, j], 1]
                if t[tr, j] == v:
                    mover[count] = j
            count += 1
    return count


@nb.njit(cache=True, inline="always")
def _merged_worst(
    xy: FloatArray, mover: IntArray, count: int, x: float, y: float, floor: float
) -> float:  # pragma: no cover - compiled
    """Worst quality of the ``count`` gathered triangles (:func:`_gather`) with the merged
    node at (x, y), or any value at or below ``floor`` once the worst is known to be there:
    the callers only ask whether it beats ``floor``. The triangle that ended a call moves to
    the front (a minimum does not depend on the order), so the next trial, nearby, usually
    fails on its first triangle."""
    worst = np.inf
    for k in range(count):
        x0, y0, x1, y1, x2, y2 = xy[k, 0], xy[k, 1], xy[k, 2], xy[k, 3], xy[k, 4], xy[k, 5]
        if mover[k] == 0:
            x0, y0 = x, y
        elif mover[k] == 1:
            x1, y1 = x, y
        else:
            x2, y2 = x, y
        worst = min(worst, shape_quality_xy(x0, y0, x1, y1, x2, y2))
        if worst <= floor:
            if k > 0:
                for j in range(6):
                    xy[0, j], xy[k, j] = xy[k, j], xy[0, j]
                mover[0], mover[k] = mover[k], mover[0]
            return worst
    return worst


@nb.njit(cache=True)
def _linked(t: IntArray, start: IntArray, tri_of: IntArray, a: int, b: int) -> bool:
    """Whether a and b share exactly two neighbours (the link condition of an interior edge)."""
    common = 0
    for k in range(start[a], start[a + 1]):
        for j in range(3):
            w = t[tri_of[k], j]
            if w in (a, b):
                continue
            dup = False  # w appears in two triangles of a's star: count it once
            for k0 in range(start[a], k):
                dup = dup or t[tri_of[k0], 0] == w or t[tri_of[k0], 1] == w
                dup = dup or t[tri_of[k0], 2] == w
            if dup:
                continue
            for k2 in range(start[b], start[b + 1]):
                if t[tri_of[k2], 0] == w or t[tri_of[k2], 1] == w or t[tri_of[k2], 2] == w:
                    common += 1
                    break
    return common == 2


@nb.njit(cache=True, parallel=True)
def _evaluate(
    p: FloatArray,
    t: IntArray,
    fixed: BoolArray,
    start: IntArray,
    tri_of: IntArray,
    ends: IntArray,
    tq: FloatArray,
) -> tuple[FloatArray, FloatArray, FloatArray]:  # pragma: no cover - compiled
    """Per candidate edge ``(kept, gone)``: worst quality around it now, after its best
    collapse, and where the merged node goes.

    A boundary node is always the kept one and stays put; otherwise the merged node goes to the
    best of the edge's ends and midpoint, refined by a compass search. -inf marks an edge that
    cannot collapse. Edges are judged apart (each with its own scratch), in parallel: the
    outcome does not depend on the number of threads.
    """
    c = len(ends)
    before = np.full(c, np.inf)
    after = np.full(c, -np.inf)
    pos = np.zeros((c, 2))
    most = 0
    for v in range(len(start) - 1):
        most = max(most, start[v + 1] - start[v])
    for i in nb.prange(c):
        xy = np.empty((2 * most, 6))
        mover = np.empty(2 * most, dtype=np.int64)
        before[i], after[i], pos[i, 0], pos[i, 1] = _evaluate_edge(
            p, t, fixed, start, tri_of, ends[i, 0], ends[i, 1], tq, xy, mover
        )
    return before, after, pos


@nb.njit(cache=True)
def _evaluate_edge(
    p: FloatArray, t: IntArray, fixed: BoolArray, start: IntArray, tri_of: IntArray, a: int,
    b: int, tq: FloatArray, xy: FloatArray, mover: IntArray,
) -> tuple[float, float, float, float]:  # fmt: skip  # pragma: no cover - compiled
    """One edge of :func:`_evaluate`: (worst now, worst after, x, y); ``xy`` and ``mover`` are
    scratch for :func:`_gather`."""
    before = np.inf
    for v in (a, b):
        for k in range(start[v], start[v + 1]):
            before = min(before, tq[tri_of[k]])
    if not _linked(t, start, tri_of, a, b):
        return before, -np.inf, 0.0, 0.0
    count = _gather(p, t, start, tri_of, a, b, xy, mover)
    if fixed[a]:
        bx, by = p[a, 0], p[a, 1]
        return before, _merged_worst(xy, mover, count, bx, by, -np.inf), bx, by
    bx, by, best = p[a, 0], p[a, 1], -np.inf
    for s in (0.0, 0.5, 1.0):
        x = p[a, 0] + s * (p[b, 0] - p[a, 0])
        y = p[a, 1] + s * (p[b, 1] - p[a, 1])
        w = _merged_worst(xy, mover, count, x, y, best)
        if w > best:
            bx, by, best = x, y, w
    step = math.hypot(p[b, 0] - p[a, 0], p[b, 1] - p[a, 1]) / 2.0
    iterations = _COMPASS_ITERATIONS if best > before - _HOPELESS else 0
    for _ in range(iterations):
        improved = False
        nx, ny = bx, by
        for d in range(8):
            x, y = bx + step * _DX[d], by + step * _DY[d]
            w = _merged_worst(xy, mover, count, x, y, best)
            if w > best:
                best, nx, ny, improved = w, x, y, True
        if improved:
            bx, by = nx, ny
        else:
            step *= 0.5
    return before, best, bx, by


@nb.njit(cache=True)
def _select(
    t: IntArray, start: IntArray, tri_of: IntArray, ends: IntArray, order: IntArray, n: int
) -> IntArray:  # pragma: no cover - compiled
    """Greedy pick, in ``order``, of collapses whose neighbourhoods are disjoint."""
    marked = np.zeros(n, dtype=np.bool_)
    chosen = np.empty(len(order), dtype=np.int64)
    count = 0
    for i in order:
        busy = False
        for v in (ends[i, 0], ends[i, 1]):
            for k in range(start[v], start[v + 1]):
                for j in range(3):
                    busy = busy or marked[t[tri_of[k], j]]
        if busy:
            continue
        for v in (ends[i, 0], ends[i, 1]):
            for k in range(start[v], start[v + 1]):
                for j in range(3):
                    marked[t[tri_of[k], j]] = True
        chosen[count] = i
        count += 1
    return chosen[:count]


def _touching(tri: IntArray, nodes: BoolArray) -> BoolArray:
    """Triangles with a corner in ``nodes``."""
    return nodes[tri[:, 0]] | nodes[tri[:, 1]] | nodes[tri[:, 2]]


def _grow(tri: IntArray, nodes: BoolArray, rings: int) -> BoolArray:
    """``nodes`` grown by ``rings`` edges."""
    for _ in range(rings):
        nodes = nodes.copy()
        nodes[tri[_touching(tri, nodes)].ravel()] = True
    return nodes


def collapse_edges(mesh: Mesh, rounds: int = ROUNDS, should_stop: StopFn | None = None) -> Mesh:
    """Collapse interior edges while merging their nodes lifts the worst triangle around them.

    Returns a new mesh (fewer nodes and triangles, boundary unchanged, triangles still
    counter-clockwise), or ``mesh`` itself when no collapse helps. The first round looks at the
    whole mesh, later ones only around the previous round's collapses and the collapses it had
    to postpone, so a round costs O(n) array passes plus work in proportion to the changes.
    """
    if mesh.n_triangles < 2:
        return mesh
    points = np.array(mesh.points, dtype=np.float64)
    tri = np.array(mesh.triangles, dtype=np.int64)
    n = len(points)
    fixed = mesh.boundary_nodes
    alive = np.ones(len(tri), dtype=bool)
    valence = np.bincount(tri.ravel(), minlength=n)  # triangles per node
    merged_into = np.arange(n)
    look = np.ones(n, dtype=bool)  # nodes around which to look this round
    rows = np.arange(len(tri))
    changed = False
    for _ in range(rounds):
        if should_stop is not None and should_stop():
            raise Cancelled("stopped while collapsing edges")
        sub = tri[rows]
        tq = shape_quality(points, sub)
        star_worst = star_min(Mesh(points, sub), tq)
        edges, count, _ = edge_table(sub)
        # Only nodes whose whole star is in ``sub`` can be judged.
        whole = np.bincount(sub.ravel(), minlength=n) == valence
        a, b = edges[:, 0], edges[:, 1]
        candidate = (count == 2) & ~(fixed[a] & fixed[b]) & whole[a] & whole[b] & look[a] & look[b]
        candidate &= np.minimum(star_worst[a], star_worst[b]) < COLLAPSE_BELOW
        # A collapse removes a node: worth trying where an edge is shorter than the edges around
        # its ends, and where the merged node keeps at most eight triangles.
        candidate &= valence[a] + valence[b] <= 12
        length = np.hypot(*(points[a] - points[b]).T)
        around = np.bincount(edges.ravel(), np.repeat(length, 2), minlength=n) / np.maximum(
            np.bincount(edges.ravel(), minlength=n), 1
        )
        candidate &= 2.0 * length < around[a] + around[b]
        idx = np.flatnonzero(candidate)
        if idx.size == 0:
            break
        start, tri_of = node_stars(sub, n)
        ends = edges[idx]
        ends = np.where(fixed[ends[:, 1]][:, None], ends[:, ::-1], ends)  # [kept, gone]
        before, after, pos = _evaluate(points, sub, fixed, start, tri_of, ends, tq)
        good = np.flatnonzero(after > before + GAIN)
        if good.size == 0:
            break
        # Best outcome first; collapses whose neighbourhoods overlap a chosen one wait a round.
        order = good[np.argsort(-after[good], kind="stable")]
        chosen = _select(sub, start, tri_of, ends, order, n)
        kept, gone = ends[chosen, 0], ends[chosen, 1]
        points[kept] = pos[chosen]
        merged_into[gone] = kept
        renamed = merged_into[sub]
        flat = (renamed[:, 0] == renamed[:, 1]) | (renamed[:, 1] == renamed[:, 2])
        flat |= renamed[:, 2] == renamed[:, 0]
        valence -= np.bincount(sub.ravel(), minlength=n)
        valence += np.bincount(renamed[~flat].ravel(), minlength=n)
        tri[rows] = renamed
        alive[rows[flat]] = False
        changed = True
        postponed = np.setdiff1d(good, chosen)
        look = np.zeros(n, dtype=bool)
        look[kept] = True
        look[ends[postponed].ravel()] = True
        look = _grow(tri[alive], look, 2)
        rows = np.flatnonzero(alive & _touching(tri, _grow(tri, look, 1)))
    if not changed:
        return mesh
    keep = np.ones(n, dtype=bool)
    keep[merged_into != np.arange(n)] = False
    renumber = np.cumsum(keep) - 1
    return Mesh(points[keep], renumber[tri[alive]])
