"""Boundary side splits: a node (or one on each of two sides) on the boundary beside a flat
triangle whose corners are all fixed.

Near a corner whose first boundary nodes sit at unequal distances on its two legs (input
vertices closer than the size, a short segment beside a long one), the triangles next to the
corner's own join a rung to a far leg node and keep an angle below the corner's: nothing can
move their nodes. Each triangle with all three nodes on the boundary and an angle below
:data:`EDGE_SPLIT_BELOW` is offered, in a small cavity around it (:func:`_cavities`), a node on
one of the cavity's boundary sides joined to its corners, or where that does not reach the cap,
a node on each of two of its boundary sides with the polygon they make triangulated afresh. So
is each triangle holding an input corner whole that falls short of the isosceles triangle at
that corner: its angle cannot change, but a node on its longer leg lifts its radius ratio. The
nodes stay on the input segments, so the mesh still covers the region exactly.
"""

from __future__ import annotations

import itertools
import math
from typing import NamedTuple

import numba as nb
import numpy as np
from numpy.typing import NDArray

from .mesh import Mesh
from .quality import corner_angles, min_angle, radius_ratio
from .relax import radius_ratio_xy
from .swap import _neighbours

__all__ = ["EDGE_SPLIT_BELOW", "corner_figures", "split_sides_round"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Compass-search halvings when placing the new node.
_HALVINGS = 14
#: Triangles with all three nodes on the boundary and a smaller angle (degrees) than this are
#: offered a node on one of their boundary sides.
EDGE_SPLIT_BELOW = 30.0
#: A boundary side is split only when the cavity's smallest angle gains this much (relative) or
#: :data:`EDGE_GAIN_DEG` degrees, whichever is less.
EDGE_GAIN = 0.05
EDGE_GAIN_DEG = 0.5
#: ... or, where the smallest angle does not fall, when the worst radius ratio gains this much
#: (relative).
EDGE_RR_GAIN = 0.005
#: Degrees within which two smallest angles count as equal.
_ANGLE_TIE = 1e-6
#: Evenly spaced trial positions along a boundary side before refining the best.
_EDGE_SAMPLES = 32
#: Trial fractions along each of two boundary sides (:func:`_place_on_two_sides`).
_PAIR_SAMPLES = 8
#: Weight of the capped smallest angle (radians) against the worst radius ratio when two nodes
#: on boundary sides are placed and their polygon triangulated: the angle first.
_ANGLE_WEIGHT = 1000.0
_THIRTY = math.radians(30.0)


@nb.njit(cache=True, inline="always")
def _fan(
    p: FloatArray, ring: IntArray, x: float, y: float, sides: int
) -> tuple[float, float, float]:
    """Worst and mean radius ratio (negative when inverted) and the smallest angle (radians)
    of the triangles joining (x, y) to the first ``sides`` sides of ``ring`` (all of them
    for a closed ring, one fewer for a chain whose ends (x, y) lies between)."""
    worst, total, smallest = np.inf, 0.0, np.inf
    k = ring.shape[0]
    for i in range(sides):
        ax, ay = p[ring[i], 0], p[ring[i], 1]
        bx, by = p[ring[(i + 1) % k], 0], p[ring[(i + 1) % k], 1]
        q = radius_ratio_xy(ax, ay, bx, by, x, y)
        a = math.hypot(bx - ax, by - ay)
        b = math.hypot(x - bx, y - by)
        c = math.hypot(ax - x, ay - y)
        worst, total = min(worst, q), total + q
        smallest = min(smallest, _smallest_angle(a, b, c))
    return worst, total / sides, smallest


@nb.njit(cache=True, inline="always")
def _smallest_angle(a: float, b: float, c: float) -> float:
    """The smallest angle (radians) of the triangle with sides ``a``, ``b``, ``c``: the one
    facing the shortest side."""
    lo, m1, m2 = (a, b, c) if a <= min(b, c) else ((b, a, c) if b <= c else (c, a, b))
    cos = (m1 * m1 + m2 * m2 - lo * lo) / max(2.0 * m1 * m2, 1e-300)
    return math.acos(min(max(cos, -1.0), 1.0))


@nb.njit(cache=True, inline="always")
def _better(angle: float, worst: float, best_angle: float, best_worst: float) -> bool:
    """A larger smallest angle (radians), or an equal one and a larger worst radius ratio."""
    tie = math.radians(_ANGLE_TIE)
    return angle > best_angle + tie or (angle > best_angle - tie and worst > best_worst)


class Line(NamedTuple):
    """Where :func:`_search_line` tries a node along a segment (a named tuple: numba takes it
    whole): at fractions ``lo + span * i / n`` for ``i`` from ``first`` to ``last``, then
    halving steps from the best within ``[lo, lo + span]``."""

    lo: float
    span: float
    n: int
    first: int
    last: int


#: A node on a boundary side: 31 places strictly inside it (refined steps stay inside too).
_ON_SIDE = Line(0.0, 1.0, _EDGE_SAMPLES, 1, _EDGE_SAMPLES - 1)


@nb.njit(cache=True)
def _search_line(
    p: FloatArray, chain: IntArray, a: int, b: int, line: Line, cap: float
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Where on the segment from node ``a`` to node ``b`` a node joined to each side of the
    chain ``chain`` makes the fan's smallest angle (radians, up to ``cap``) largest, then its
    worst radius ratio: (the fraction from ``a``, that smallest angle, the worst; -inf when no
    fan is valid)."""
    k = chain.shape[0]
    ax, ay = p[a, 0], p[a, 1]
    dx, dy = p[b, 0] - ax, p[b, 1] - ay
    at, smallest, worst = 0.5, -np.inf, -np.inf
    for i in range(line.first, line.last + 1):
        s = line.lo + line.span * i / line.n
        w, _, angle = _fan(p, chain, ax + s * dx, ay + s * dy, k - 1)
        if w > 0.0 and _better(min(angle, cap), w, smallest, worst):
            at, smallest, worst = s, min(angle, cap), w
    step = 0.5 * line.span / line.n
    for _ in range(_HALVINGS):
        for s in (at - step, at + step):
            if line.lo <= s <= line.lo + line.span:
                w, _, angle = _fan(p, chain, ax + s * dx, ay + s * dy, k - 1)
                if w > 0.0 and _better(min(angle, cap), w, smallest, worst):
                    at, smallest, worst = s, min(angle, cap), w
        step *= 0.5
    return at, smallest, worst


@nb.njit(cache=True)
def _score(poly: FloatArray, i: int, m: int, j: int) -> float:  # pragma: no cover - compiled
    """How triangle (i, m, j) of the polygon ``poly`` serves a triangulation: its smallest
    angle up to 30 degrees first, its radius ratio second; -inf when it is not counter-clockwise
    or holds another corner of the polygon."""
    ax, ay, bx, by = poly[i, 0], poly[i, 1], poly[m, 0], poly[m, 1]
    cx, cy = poly[j, 0], poly[j, 1]
    q = radius_ratio_xy(ax, ay, bx, by, cx, cy)
    if q <= 0.0:
        return -np.inf
    for w in range(poly.shape[0]):
        if w in (i, m, j):
            continue
        x, y = poly[w, 0], poly[w, 1]
        d1 = (bx - ax) * (y - ay) - (by - ay) * (x - ax)
        d2 = (cx - bx) * (y - by) - (cy - by) * (x - bx)
        d3 = (ax - cx) * (y - cy) - (ay - cy) * (x - cx)
        if d1 > 0.0 and d2 > 0.0 and d3 > 0.0:
            return -np.inf
    a = math.hypot(cx - bx, cy - by)
    b = math.hypot(ax - cx, ay - cy)
    c = math.hypot(bx - ax, by - ay)
    return _ANGLE_WEIGHT * min(_smallest_angle(a, b, c), _THIRTY) + q


@nb.njit(cache=True)
def _triangulate(poly: FloatArray, choice: IntArray) -> float:  # pragma: no cover - compiled
    """The best triangulation of the polygon ``poly`` (counter-clockwise) by the worst
    :func:`_score` of its triangles (dynamic programming over its chords: ``choice[i, j]``
    is the apex over chord i-j); returns that worst score."""
    k = poly.shape[0]
    value = np.full((k, k), np.inf)
    for gap in range(2, k):
        for i in range(k - gap):
            j = i + gap
            best, arg = -np.inf, -1
            for m in range(i + 1, j):
                v = min(_score(poly, i, m, j), value[i, m], value[m, j])
                if v > best:
                    best, arg = v, m
            value[i, j], choice[i, j] = best, arg
    return value[0, k - 1]


@nb.njit(cache=True)
def _two_on_sides(
    p: FloatArray, ring: IntArray, s1: int, s2: int, u: float, v: float, choice: IntArray
) -> tuple[FloatArray, float]:  # pragma: no cover - compiled
    """The polygon of ``ring`` with a node at fraction ``u`` along its side ``s1`` (from
    ``ring[s1]`` to the next corner) and one at ``v`` along ``s2``, and its best score."""
    k = ring.shape[0]
    poly = np.empty((k + 2, 2))
    n = 0
    for a in range(k):
        poly[n, 0], poly[n, 1] = p[ring[a], 0], p[ring[a], 1]
        n += 1
        if a in (s1, s2):
            f = u if a == s1 else v
            b = ring[(a + 1) % k]
            poly[n, 0] = p[ring[a], 0] + f * (p[b, 0] - p[ring[a], 0])
            poly[n, 1] = p[ring[a], 1] + f * (p[b, 1] - p[ring[a], 1])
            n += 1
    return poly, _triangulate(poly, choice)


@nb.njit(cache=True)
def _place_on_two_sides(
    p: FloatArray, ring: IntArray, s1: int, s2: int
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """Where on the boundary sides ``s1`` and ``s2`` of ``ring`` two nodes, the polygon then
    triangulated by :func:`_triangulate`, make the worst score best: (the fractions along the
    two sides, that score; -inf when no triangulation is valid)."""
    choice = np.zeros((ring.shape[0] + 2, ring.shape[0] + 2), dtype=np.int64)
    bu, bv, best = 0.5, 0.5, -np.inf
    for i in range(1, _PAIR_SAMPLES):
        for j in range(1, _PAIR_SAMPLES):
            u, v = i / _PAIR_SAMPLES, j / _PAIR_SAMPLES
            score = _two_on_sides(p, ring, s1, s2, u, v, choice)[1]
            if score > best:
                bu, bv, best = u, v, score
    step = 0.5 / _PAIR_SAMPLES
    for _ in range(_HALVINGS):
        for du, dv in ((-step, 0.0), (step, 0.0), (0.0, -step), (0.0, step)):
            u, v = bu + du, bv + dv
            if 0.0 < u < 1.0 and 0.0 < v < 1.0:
                score = _two_on_sides(p, ring, s1, s2, u, v, choice)[1]
                if score > best:
                    bu, bv, best = u, v, score
        step *= 0.5
    return bu, bv, best


def _chords(choice: IntArray, i: int, j: int) -> list[tuple[int, int, int]]:
    """The triangles (polygon positions) :func:`_triangulate` chose under chord i-j."""
    if j - i < 2:
        return []
    m = int(choice[i, j])
    return [(i, m, j), *_chords(choice, i, m), *_chords(choice, m, j)]


def _cavities(tri: IntArray, nbr: IntArray, t: int) -> list[tuple[list[int], list[int]]]:
    """The cavities offered around triangle ``t``: (triangles, corners counter-clockwise)."""
    sides = [k for k in range(3) if nbr[t, k] >= 0]
    options: list[list[int]] = [[]] + [[k] for k in sides] + ([sides] if len(sides) > 1 else [])
    out = []
    for chosen in options:
        ring: list[int] = []
        tris = [t]
        for j in range(3):
            ring.append(int(tri[t, j]))
            k = (j + 2) % 3  # the side from corner j to corner j + 1
            if k in chosen:
                n = int(nbr[t, k])
                apex = [int(v) for v in tri[n] if v != tri[t, j] and v != tri[t, (j + 1) % 3]]
                ring.append(apex[0])
                tris.append(n)
        out.append((tris, ring))
    return out


def split_sides_round(
    mesh: Mesh, held: frozenset[tuple[float, float, float, float]] = frozenset()
) -> Mesh | None:
    """A node on a boundary side of a small cavity (as in :func:`_cavities`) around each
    triangle that has all three nodes on the boundary and an angle below
    :data:`EDGE_SPLIT_BELOW`, joined to the cavity's corners (:func:`_one_node`), or where
    none reaches that angle a node on each of two sides (:func:`_two_nodes`), where that lifts
    the cavity's smallest angle by :data:`EDGE_GAIN` (or :data:`EDGE_GAIN_DEG`) without lowering
    its worst radius ratio; None when nothing was split.

    Near a corner whose first boundary nodes sit at unequal distances on its two legs (input
    vertices closer than the size, a short segment beside a long one) the corner's triangle has
    a second angle below the corner's own: a node on the longer leg at the shorter leg's
    distance makes it isosceles. The node stays on the input segment, so the mesh still covers
    the region exactly. Sides in ``held`` (by their ends' coordinates) are never split.
    """
    if mesh.n_triangles == 0:
        return None
    tri, p = mesh.triangles, mesh.points
    angle, held_whole, flat = corner_figures(mesh)
    candidates = np.flatnonzero((angle < EDGE_SPLIT_BELOW) & ~held_whole | flat)
    if candidates.size == 0:
        return None
    bound = _corner_bound(mesh)
    nbr = _neighbours(tri)
    boundary = {
        (a, b)
        for a, b in mesh.boundary_edges.tolist()
        if (*p[a].tolist(), *p[b].tolist()) not in held
    }
    used = np.zeros(len(tri), dtype=bool)
    new_points: list[FloatArray] = []
    fans: list[IntArray] = []
    for t in candidates[np.argsort(angle[candidates], kind="stable")].tolist():
        best: _SideSplit | None = None
        offers: list[tuple[list[int], list[int], list[int], float, float]] = []
        for tris, ring in _cavities(tri, nbr, t):
            if used[tris].any():
                continue
            old = tri[tris]
            least = float(min_angle(p, old).min())
            floor = float(radius_ratio(p, old).min())
            sides = [
                a for a in range(len(ring)) if (ring[a], ring[(a + 1) % len(ring)]) in boundary
            ]
            offers.append((tris, ring, sides, least, floor))
        # A node on two sides (a search some hundred times dearer) only below the bound the
        # input sets, where one does not reach the cap, and not for a corner held whole (one
        # node makes its triangle isosceles).
        pair = angle[t] < bound and not held_whole[t]
        for tries in (_one_node, _two_nodes) if pair else (_one_node,):
            if best is not None and best[0] >= EDGE_SPLIT_BELOW:
                break
            for tris, ring, sides, least, floor in offers:
                for smallest, worst, xy, polygon in tries(p, ring, sides):
                    key = (round(min(smallest, EDGE_SPLIT_BELOW), 6), worst)
                    if _gains(smallest, worst, least, floor) and (best is None or key > best[:2]):
                        best = (*key, xy, polygon, tris)
        if best is None:
            continue
        _, _, xy, polygon, tris = best
        used[tris] = True
        node = mesh.n_points + len(new_points)
        new_points.extend(xy)
        # The polygon's corners: the mesh's nodes, the new ones as -1, -2 in order.
        index = np.array([v if v >= 0 else node - v - 1 for v in polygon[0]], dtype=np.int64)
        fans.append(index[polygon[1]])
    if not fans:
        return None
    return Mesh(
        np.concatenate([p, np.asarray(new_points)]),
        np.concatenate([tri[~used], *fans]).astype(np.int64),
    )


def corner_figures(mesh: Mesh) -> tuple[FloatArray, BoolArray, BoolArray]:
    """Per triangle: its smallest angle (degrees; inf unless all its nodes are on the
    boundary), whether that angle is an input corner held whole (its node has no other
    triangle: nothing changes that angle), and whether it holds an input corner whole with a
    radius ratio more than :data:`EDGE_RR_GAIN` under the isosceles triangle's at that corner,
    the best it can be (the corner's first boundary nodes at unequal distances on its legs)."""
    tri, p = mesh.triangles, mesh.points
    spanning = mesh.boundary_nodes[tri].all(axis=1)
    corners = corner_angles(p, tri[spanning])
    angle = np.full(len(tri), np.inf)
    angle[spanning] = corners.min(axis=1)
    held_whole = np.zeros(len(tri), dtype=bool)
    lone = np.bincount(tri.ravel(), minlength=mesh.n_points)[tri[spanning]] == 1
    held_whole[spanning] = np.take_along_axis(lone, corners.argmin(axis=1)[:, None], 1)[:, 0]
    corner = np.where(lone, corners, np.inf).min(axis=1)  # the input corner it holds whole
    flat = np.zeros(len(tri), dtype=bool)
    ratio = radius_ratio(p, tri[spanning])
    flat[spanning] = ratio * (1.0 + EDGE_RR_GAIN) < _isosceles_ratio(np.radians(corner))
    return angle, held_whole, flat


def _corner_bound(mesh: Mesh) -> float:
    """min(the smallest angle of the region at a boundary node, :data:`EDGE_SPLIT_BELOW`)
    (degrees): the smallest angle the input lets a mesh reach."""
    tri = mesh.triangles
    near = mesh.boundary_nodes[tri].any(axis=1)
    total = np.zeros(mesh.n_points)
    np.add.at(total, tri[near].ravel(), corner_angles(mesh.points, tri[near]).ravel())
    return min(float(total[mesh.boundary_nodes].min()), EDGE_SPLIT_BELOW)


def _isosceles_ratio(apex: FloatArray) -> FloatArray:
    """Radius ratio of the isosceles triangle with apex angle ``apex`` (radians; 0 for an
    infinite one): the best a triangle holding an input corner of that angle whole can have."""
    apex = np.where(np.isfinite(apex), apex, 0.0)
    return np.asarray(8.0 * np.sin(apex / 2.0) * np.sin((np.pi - apex) / 4.0) ** 2)


def _gains(smallest: float, worst: float, least: float, floor: float) -> bool:
    """Whether a split whose smallest angle (degrees) and worst radius ratio are ``smallest``
    and ``worst`` improves on a cavity's ``least`` and ``floor``: its smallest angle gains
    :data:`EDGE_GAIN` (or :data:`EDGE_GAIN_DEG`) and its worst does not fall, or its smallest
    angle does not fall and its worst gains :data:`EDGE_RR_GAIN`.

    At a sharp input corner whose legs end at input vertices at unequal distances, the
    corner's triangle keeps the corner's angle whatever is done (15 degrees beside a reflex
    corner of a random region), yet its third side is flat (149 degrees, radius ratio 0.142); a
    node on the longer leg makes it isosceles (0.454) without changing its smallest angle.
    """
    by_angle = smallest >= least + min(least * EDGE_GAIN, EDGE_GAIN_DEG) and worst >= floor
    by_ratio = smallest >= least - _ANGLE_TIE and worst >= floor * (1.0 + EDGE_RR_GAIN)
    return by_angle or by_ratio


#: A boundary-side split: (its smallest angle in degrees, its worst radius ratio, the new
#: nodes, the polygon (ring corners with the new nodes as -1, -2) and its triangles by polygon
#: position).
_Split = tuple[float, float, list[FloatArray], tuple[list[int], IntArray]]
_SideSplit = tuple[float, float, list[FloatArray], tuple[list[int], IntArray], list[int]]


def _one_node(p: FloatArray, ring: list[int], sides: list[int]) -> list[_Split]:
    """A node on each boundary side of ``ring`` in turn, joined to the ring's corners."""
    out = []
    for a in sides:
        chain = ring[a + 1 :] + ring[: a + 1]  # from the side's end round to its start
        # Along the side from its start (the chain's last node) to its end (the first).
        links = np.asarray(chain, dtype=np.int64)
        at, smallest, worst = _search_line(p, links, chain[-1], chain[0], _ON_SIDE, np.inf)
        xy = p[chain[-1]] + at * (p[chain[0]] - p[chain[-1]])
        k = len(chain)
        fan = np.array([[i, i + 1, k] for i in range(k - 1)], dtype=np.int64)
        out.append((math.degrees(smallest), worst, [xy], ([*chain, -1], fan)))
    return out


def _two_nodes(p: FloatArray, ring: list[int], sides: list[int]) -> list[_Split]:
    """A node on each of two boundary sides of ``ring``, the polygon they make triangulated
    for its smallest angle (up to 30 degrees), then its worst radius ratio.

    Where a sharp corner's legs carry nodes at unequal distances (input vertices closer than
    the size), the triangle beside the corner's own joins a rung to a far leg node: a 37-degree
    spike kept 28.5 degrees there, since a node on either leg alone leaves that angle, while a
    node on each leg makes a ladder of two more rungs (31.8 degrees).
    """
    out = []
    ring_arr = np.asarray(ring, dtype=np.int64)
    for s1, s2 in itertools.combinations(sides, 2):
        u, v, score = _place_on_two_sides(p, ring_arr, s1, s2)
        if not math.isfinite(score):
            continue
        choice = np.zeros((len(ring) + 2, len(ring) + 2), dtype=np.int64)
        poly, _ = _two_on_sides(p, ring_arr, s1, s2, u, v, choice)
        triangles = np.array(_chords(choice, 0, len(poly) - 1), dtype=np.int64)
        corners: list[int] = []
        for a, c in enumerate(ring):
            corners.append(c)
            if a in (s1, s2):
                corners.append(-1 if a == s1 else -2)
        smallest = float(min_angle(poly, triangles).min())
        worst = float(radius_ratio(poly, triangles).min())
        xy = [poly[corners.index(-1)], poly[corners.index(-2)]]
        out.append((smallest, worst, xy, (corners, triangles)))
    return out
