"""Diagonal swapping: flip interior edges while that improves the worse of their two triangles.

An interior edge shared by triangles (c, a, b) and (d, b, a) is replaced by the edge c-d when the
quadrilateral a-d-b-c is strictly convex and the worse of the two new triangles is better than
the worse of the two old ones (by shape quality). Each flip raises the sorted vector of triangle
qualities lexicographically, so the process terminates; a small relative margin keeps rounding
from ever flipping an edge back.

>>> import numpy as np
>>> from engine.mesh import Mesh
>>> pts = np.array([[0.0, 0.0], [1.0, 0.0], [1.1, 0.2], [0.0, 0.25]])
>>> swapped = swap_diagonals(Mesh(pts, np.array([[0, 1, 2], [0, 2, 3]])))
>>> swapped.triangles.tolist()
[[1, 2, 3], [3, 0, 1]]
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from .mesh import Mesh
from .quality import corner_angles, shape_quality
from .relax import node_stars
from .relax import relax as relax_nodes

__all__ = ["regularise_valence", "swap_diagonals"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

_FOUR_SQRT3 = 4.0 * math.sqrt(3.0)
#: Relaxation sweeps before swapping (``relax=True``).
_RELAX_SWEEPS = 10
#: A flip must raise the worse quality by more than this relative margin (rounding headroom).
_MARGIN = 1e-12
#: Valence flips: both new triangles at least this quality, and this fraction of the old worse
#: one; the smoother that follows moves the nodes of the new connectivity.
_VALENCE_Q_FLOOR = 0.5
_VALENCE_Q_RATIO = 0.75
_VALENCE_SWEEPS = 10
#: No flip splits a boundary corner sharper than twice this (degrees) where the pair had no
#: smaller angle (:func:`_corner_floor`).
_FLOOR_CAP = 30.0
#: Degrees within which a split piece counts as no smaller than the pair's smallest angle.
_ANGLE_TIE = 1e-9


@numba.njit(cache=True, inline="always")
def _quality(p: FloatArray, i: int, j: int, k: int) -> float:
    ax, ay, bx, by, cx, cy = p[i, 0], p[i, 1], p[j, 0], p[j, 1], p[k, 0], p[k, 1]
    area = 0.5 * ((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))
    s = (cx - bx) ** 2 + (cy - by) ** 2 + (ax - cx) ** 2 + (ay - cy) ** 2
    s += (bx - ax) ** 2 + (by - ay) ** 2
    return _FOUR_SQRT3 * area / max(s, 1e-300)


@numba.njit(cache=True, inline="always")
def _angle(p: FloatArray, apex: int, u: int, v: int) -> float:
    """The angle (degrees) at ``apex`` between the rays to ``u`` and ``v``."""
    ux, uy = p[u, 0] - p[apex, 0], p[u, 1] - p[apex, 1]
    vx, vy = p[v, 0] - p[apex, 0], p[v, 1] - p[apex, 1]
    return math.degrees(math.atan2(abs(ux * vy - uy * vx), ux * vx + uy * vy))


@numba.njit(cache=True)
def _splits_below_floor(p: FloatArray, floor: FloatArray, c: int, a: int, b: int, d: int) -> bool:
    """Whether flipping a-b (triangles (c, a, b) and (d, b, a)) to c-d splits the angle at c
    or d into a piece below that node's ``floor`` and below the pair's smallest angle before.

    The flip merges the angles at a and b and splits those at c and d, so only c's and d's
    new angles can be smaller than any angle before. Radius ratio and shape quality can still
    improve while a boundary corner is halved (a 56-degree corner into 28-degree pieces when
    the pair's smallest angle was 30), so the smallest angle is checked on its own.
    """
    if floor[c] <= 0.0 and floor[d] <= 0.0:
        return False
    before = min(
        _angle(p, c, a, b), _angle(p, a, b, c), _angle(p, b, c, a),
        _angle(p, d, b, a), _angle(p, b, a, d), _angle(p, a, d, b),
    )  # fmt: skip
    for v, w in ((c, d), (d, c)):
        if floor[v] <= 0.0:
            continue
        least = min(_angle(p, v, a, w), _angle(p, v, w, b))
        if least < floor[v] and least < before - _ANGLE_TIE:
            return True
    return False


@numba.njit(cache=True, inline="always")
def _flip(
    tri: IntArray, nbr: IntArray, locked: BoolArray, t1: int, k1: int, t2: int, k2: int
) -> None:
    """Flip the edge between triangle ``t1`` (side ``k1``) and ``t2`` (side ``k2``) in place.

    With t1 = (c, a, b) and t2's corner d opposite the edge, t1 becomes (c, a, d) and t2
    becomes (d, b, c); side k is opposite corner k, and the outer neighbours follow.
    """
    c, a, b, d = tri[t1, k1], tri[t1, (k1 + 1) % 3], tri[t1, (k1 + 2) % 3], tri[t2, k2]
    n_bc, n_ca = nbr[t1, (k1 + 1) % 3], nbr[t1, (k1 + 2) % 3]
    n_ad, n_db = nbr[t2, (k2 + 1) % 3], nbr[t2, (k2 + 2) % 3]
    l_bc, l_ca = locked[t1, (k1 + 1) % 3], locked[t1, (k1 + 2) % 3]
    l_ad, l_db = locked[t2, (k2 + 1) % 3], locked[t2, (k2 + 2) % 3]
    tri[t1, 0], tri[t1, 1], tri[t1, 2] = c, a, d
    nbr[t1, 0], nbr[t1, 1], nbr[t1, 2] = n_ad, t2, n_ca
    locked[t1, 0], locked[t1, 1], locked[t1, 2] = l_ad, False, l_ca
    tri[t2, 0], tri[t2, 1], tri[t2, 2] = d, b, c
    nbr[t2, 0], nbr[t2, 1], nbr[t2, 2] = n_bc, t1, n_db
    locked[t2, 0], locked[t2, 1], locked[t2, 2] = l_bc, False, l_db
    for t_out, t_new in ((n_ad, t1), (n_bc, t2)):
        if t_out >= 0:
            for k in range(3):
                if nbr[t_out, k] == (t2 if t_new == t1 else t1):
                    nbr[t_out, k] = t_new


@numba.njit(cache=True)
def _flip_all(
    points: FloatArray,
    tri: IntArray,
    nbr: IntArray,
    locked: BoolArray,
    order: IntArray,
    floor: FloatArray,
) -> int:
    """Flip until no flip helps; ``tri``/``nbr``/``locked`` (per triangle side) change in place.

    Side k of a triangle is opposite its corner k; ``nbr`` holds the triangle across each side
    (-1 on the boundary) and ``locked`` marks sides that never flip. ``order`` lists the
    (triangle, side) keys ``3 t + k`` to examine first; every flip queues the four outer sides of
    its quadrilateral again. No flip splits a node's angle below its ``floor`` (degrees) where the
    pair had no smaller angle (:func:`_splits_below_floor`). Returns the number of flips.
    """
    m = len(tri)
    stack = np.empty(3 * m + 4, dtype=np.int64)
    queued = np.zeros(3 * m, dtype=np.bool_)
    top = 0
    for key in order[::-1]:
        stack[top] = key
        queued[key] = True
        top += 1
    flips = 0
    while top > 0:
        top -= 1
        key = stack[top]
        queued[key] = False
        t1, k1 = key // 3, key % 3
        t2 = nbr[t1, k1]
        if t2 < 0 or locked[t1, k1]:
            continue
        c, a, b = tri[t1, k1], tri[t1, (k1 + 1) % 3], tri[t1, (k1 + 2) % 3]
        k2 = 0
        while nbr[t2, k2] != t1:
            k2 += 1
        d = tri[t2, k2]
        old = min(_quality(points, c, a, b), _quality(points, d, b, a))
        new = min(_quality(points, c, a, d), _quality(points, d, b, c))
        # Both new triangles positive <=> the quadrilateral a-d-b-c is strictly convex.
        if not (new > 0.0 and new > old + _MARGIN * abs(old)):
            continue
        if _splits_below_floor(points, floor, c, a, b, d):
            continue
        _flip(tri, nbr, locked, t1, k1, t2, k2)
        flips += 1
        for key2 in (3 * t1, 3 * t1 + 2, 3 * t2, 3 * t2 + 2):
            if not queued[key2]:
                stack[top] = key2
                queued[key2] = True
                top += 1
    return flips


@numba.njit(cache=True, inline="always")
def _valence_cost(angle_sum: float, triangles: int) -> float:
    """How far a node's mean angle is from 60 degrees, squared: 0 for six triangles around an
    interior node, for three along a straight boundary, for two at a 120-degree corner."""
    return (angle_sum / triangles - 60.0) ** 2


@numba.njit(cache=True)
def _flip_valence(
    points: FloatArray, tri: IntArray, nbr: IntArray, locked: BoolArray, angle_sum: FloatArray,
    floor: FloatArray, sweeps: int,
) -> int:  # fmt: skip
    """Flip edges that bring nodes closer to a 60-degree mean angle; returns the flips.

    ``angle_sum`` is the angle around each node in degrees (360 inside, the domain's angle on
    the boundary: that never changes, as boundary nodes stay). An edge a-b (triangles (c, a, b)
    and (d, b, a)) becomes c-d when that lowers the sum of :func:`_valence_cost` over a, b, c,
    d, neither a nor b drops to three triangles (or to one, on the boundary), and both new
    triangles keep quality >= ``_VALENCE_Q_FLOOR`` and >= ``_VALENCE_Q_RATIO`` times the old
    worse one, and no angle is split below ``floor`` (as in :func:`_flip_all`). The sum falls
    with every flip, so it ends. A boundary node with one triangle too few (two of 93 degrees on
    a hole's edge) takes one from its neighbour with one too many: no node move could mend it,
    boundary nodes being fixed.
    """
    m = len(tri)
    val = np.zeros(len(points), dtype=np.int64)
    for t in range(m):
        for k in range(3):
            val[tri[t, k]] += 1
    flips = 0
    for _ in range(sweeps):
        changed = 0
        for t1 in range(m):
            for k1 in range(3):
                t2 = nbr[t1, k1]
                if t2 < t1 or locked[t1, k1]:
                    continue
                c, a, b = tri[t1, k1], tri[t1, (k1 + 1) % 3], tri[t1, (k1 + 2) % 3]
                floor_a = 3 if angle_sum[a] >= 360.0 else 1
                floor_b = 3 if angle_sum[b] >= 360.0 else 1
                if val[a] <= floor_a or val[b] <= floor_b:
                    continue
                k2 = 0
                while nbr[t2, k2] != t1:
                    k2 += 1
                d = tri[t2, k2]
                before = 0.0
                after = 0.0
                for v, dv in ((a, -1), (b, -1), (c, 1), (d, 1)):
                    before += _valence_cost(angle_sum[v], val[v])
                    after += _valence_cost(angle_sum[v], val[v] + dv)
                if after >= before - 1e-9:
                    continue
                old = min(_quality(points, c, a, b), _quality(points, d, b, a))
                new = min(_quality(points, c, a, d), _quality(points, d, b, c))
                if not (new >= _VALENCE_Q_FLOOR and new >= _VALENCE_Q_RATIO * old):
                    continue
                if _splits_below_floor(points, floor, c, a, b, d):
                    continue
                _flip(tri, nbr, locked, t1, k1, t2, k2)
                val[a] -= 1
                val[b] -= 1
                val[c] += 1
                val[d] += 1
                changed += 1
                break  # t1 changed: its other sides are looked at in the next sweep
        flips += changed
        if changed == 0:
            break
    return flips


def _neighbours(triangles: IntArray) -> IntArray:
    """Triangle across each side (side k opposite corner k), -1 on the boundary."""
    tri = np.ascontiguousarray(triangles, dtype=np.int64)
    n = int(tri.max()) + 1 if len(tri) else 1
    start, tri_of = node_stars(tri, n)
    return _across(tri, start, tri_of)


@numba.njit(cache=True)
def _across(tri: IntArray, start: IntArray, tri_of: IntArray) -> IntArray:
    """:func:`_neighbours` from the node stars, without sorting every side.

    The sides of one undirected edge, in side order (``3 t + k``), are S0 < S1 < ...; S0 faces
    S1's triangle and every later one the one before it, as the pairing of consecutive sorted
    sides always gave (only a non-manifold edge has more than two).
    """
    m = len(tri)
    nbr = np.full((m, 3), -1, dtype=np.int64)
    for t in range(m):
        for k in range(3):
            a, b = tri[t, (k + 1) % 3], tri[t, (k + 2) % 3]
            before, after = -1, -1  # sides of edge {a, b}: the last before this one, the next
            found = False
            last_tri = -1
            for j in range(start[a], start[a + 1]):
                t2 = tri_of[j]
                if t2 == last_tri:  # a repeated corner lists a triangle twice
                    continue
                last_tri = t2
                for k2 in range(3):
                    c, d = tri[t2, (k2 + 1) % 3], tri[t2, (k2 + 2) % 3]
                    if not ((c == a and d == b) or (c == b and d == a)):
                        continue
                    side = 3 * t2 + k2
                    if side < 3 * t + k:
                        before = side
                    elif side == 3 * t + k:
                        found = True
                    elif found and after < 0:
                        after = side
            if before >= 0:
                nbr[t, k] = before // 3
            elif after >= 0:
                nbr[t, k] = after // 3
    return nbr


def _locked(
    tri: IntArray, nbr: IntArray, fixed_edges: NDArray[np.int64] | None, n_points: int
) -> BoolArray:
    """(m, 3) sides that never flip: boundary sides and the ``fixed_edges``."""
    locked: BoolArray = nbr < 0
    if fixed_edges is not None and len(fixed_edges):
        fixed = np.sort(np.asarray(fixed_edges, dtype=np.int64).reshape(-1, 2), axis=1)
        sides = np.sort(np.stack([tri[:, [1, 2]], tri[:, [2, 0]], tri[:, [0, 1]]], axis=1), axis=2)
        n = max(n_points, int(fixed.max()) + 1)
        side_key = sides[..., 0] * n + sides[..., 1]
        locked |= np.isin(side_key, fixed[:, 0] * n + fixed[:, 1])
    return locked


def _angle_sums(mesh: Mesh, points: FloatArray, tri: IntArray) -> FloatArray:
    """The angle (degrees) around each node: 360 inside, the domain's angle on the boundary."""
    angle_sum = np.full(len(points), 360.0)
    on_boundary = mesh.boundary_nodes
    angles = corner_angles(points, tri)
    angle_sum[on_boundary] = np.bincount(tri.ravel(), angles.ravel(), len(points))[on_boundary]
    return angle_sum


def _corner_floor(on_boundary: BoolArray, angle_sum: FloatArray) -> FloatArray:
    """Per node, the angle (degrees) no flip may split below: at a boundary corner sharper than
    twice :data:`_FLOOR_CAP` the bound it sets, min(its angle, 30), as any split of it falls
    below that; 0 elsewhere (a node moved by the smoother, or a corner that a split may leave
    above the bound: on the jittered benchmark meshes a floor at every boundary node held back
    flips that the smoother needed, worst radius ratio 0.821 -> 0.804 on the annulus)."""
    sharp = on_boundary & (angle_sum < 2.0 * _FLOOR_CAP)
    floor: FloatArray = np.where(sharp, np.minimum(angle_sum, _FLOOR_CAP), 0.0)
    return floor


def swap_diagonals(
    mesh: Mesh, fixed_edges: NDArray[np.int64] | None = None, *, relax: bool = False
) -> Mesh:
    """Flip interior edges while the worse of the two triangles improves.

    Boundary edges and the edges listed in ``fixed_edges`` ((k, 2) vertex pairs, any order)
    never flip. Returns a new mesh (the input is not modified) whose triangles stay
    counter-clockwise, with the same points unless ``relax``. Runs in O(n + flips) after an
    O(n log n) set-up. A flip never splits a boundary corner sharper than 60 degrees (each
    piece falls below the bound min(corner, 30) it sets) unless the pair had a smaller angle
    before: radius ratio can improve while a corner is halved.

    ``relax`` first moves interior nodes by the mesher's constrained relaxation
    (:func:`engine.relax.relax`, which never lowers the worst triangle), so that
    flips are decided on settled positions: swapping a mesh whose nodes are merely displaced
    otherwise rewires it around the displacements and locks in irregular connectivity (on the
    jittered benchmark meshes, swap-then-GA ends with 62-73% of triangles at quality >= 0.91,
    relax-swap-GA with 91-95%, GA alone with 89-95%).
    """
    tri = np.array(mesh.triangles, dtype=np.int64, order="C")
    m = len(tri)
    if relax:
        mesh = relax_nodes(mesh, sweeps=_RELAX_SWEEPS)
    if m < 2:
        return mesh
    points = np.ascontiguousarray(mesh.points, dtype=np.float64)
    nbr = _neighbours(tri)
    locked = _locked(tri, nbr, fixed_edges, len(points))
    # Start from the sides of the worst triangles, so they are repaired first.
    q = shape_quality(points, tri)
    order = (3 * np.argsort(q, kind="stable")[:, None] + np.arange(3)).ravel()
    floor = _corner_floor(mesh.boundary_nodes, _angle_sums(mesh, points, tri))
    _flip_all(points, tri, nbr, locked, order, floor)
    return Mesh(mesh.points, tri)


def regularise_valence(mesh: Mesh, fixed_edges: NDArray[np.int64] | None = None) -> Mesh | None:
    """Flip edges toward a 60-degree mean angle at every node (six triangles inside), then
    relax; None when nothing flips. Boundary edges and ``fixed_edges`` never flip, and the
    relaxation holds ``mesh.boundary_nodes`` (pinned nodes of a
    :class:`~engine.constraints.PinnedMesh` too).

    Unlike :func:`swap_diagonals` this may lower the worst triangle (never below quality
    ``_VALENCE_Q_FLOOR``): it prepares connectivity for a smoother, and
    :func:`engine.mesh_then_smooth` keeps its result only if the smoothed mesh's worst triangle
    is no worse than smoothing without it gives. A node of valence 9 caps its angles at 40
    degrees on average, one of valence 4 forces a right-angled neighbourhood.

    >>> import numpy as np
    >>> pts = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    >>> regularise_valence(Mesh(pts, np.array([[0, 1, 2], [0, 2, 3]]))) is None  # no interior node
    True
    """
    tri = np.array(mesh.triangles, dtype=np.int64, order="C")
    if len(tri) < 2:
        return None
    points = np.ascontiguousarray(mesh.points, dtype=np.float64)
    nbr = _neighbours(tri)
    locked = _locked(tri, nbr, fixed_edges, len(points))
    on_boundary = mesh.boundary_nodes
    angle_sum = _angle_sums(mesh, points, tri)
    floor = _corner_floor(on_boundary, angle_sum)
    if _flip_valence(points, tri, nbr, locked, angle_sum, floor, _VALENCE_SWEEPS) == 0:
        return None
    return relax_nodes(Mesh(mesh.points, tri), sweeps=_RELAX_SWEEPS, fixed=on_boundary)
