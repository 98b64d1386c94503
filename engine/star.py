"""Node stars and the exact per-node fitness kernels every smoother decides with.

A node's *star* is the list of triangles that use it, in increasing triangle index. Each star
triangle is stored by its two other corners ``(a, b)``, ordered so that ``(node, a, b)`` is
counter-clockwise; moving the node to ``(x, y)`` turns it into ``((x, y), a, b)``.

The kernels here compute the fitness of :mod:`engine.fitness` exactly (same formulas, same
summation order for a node wherever it is evaluated), so that the value a smoother accepts a move
with is bit for bit the value reported afterwards.

>>> import numpy as np
>>> tri = np.array([[0, 1, 2], [0, 2, 3]])
>>> stars = build_stars(tri, 4)
>>> stars.ptr.tolist(), stars.opp_a.tolist(), stars.opp_b.tolist()
([0, 2, 3, 5, 6], [1, 2, 2, 0, 3, 0], [2, 3, 0, 1, 0, 2])
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from .mesh import corner_order

__all__ = [
    "ANGLE",
    "ASPECT",
    "CAPPED",
    "COMBINED",
    "FITNESS_KINDS",
    "MIN_QUALITY",
    "NEEDS_ANGLE",
    "WORST",
    "Stars",
    "all_fitness",
    "build_stars",
    "combine",
    "mark_neighbours",
    "star_fitness",
    "star_min_qualities",
    "star_min_quality",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: The fitness functions the kernels know, one row each: (name, whether it uses the angle
#: term). A row's index is the fitness's code in the kernels and :func:`combine` is its
#: formula. **To add a fitness**: add a row here, its branch in :func:`combine`, and its plain
#: numpy statement to :data:`engine.fitness.REFERENCE` (the tests hold the kernels to it);
#: every smoother, the reports and the service's choices follow from these.
FITNESS_KINDS: tuple[tuple[str, bool], ...] = (
    ("angle", True),
    ("aspect", False),
    ("combined", True),
    ("worst", False),
    ("capped", True),
)
#: Fitness kind codes (row indices of :data:`FITNESS_KINDS`).
ANGLE, ASPECT, COMBINED, WORST, CAPPED = range(len(FITNESS_KINDS))
#: Per code: whether the fitness uses the angle term (kernels skip the arctangents if not).
NEEDS_ANGLE = tuple(uses for _, uses in FITNESS_KINDS)
#: A move is admissible only when every triangle of the star keeps a shape quality above this: no
#: inversion, and a margin from degeneracy so results always pass :func:`engine.validate_mesh`.
MIN_QUALITY = 1e-6
#: ``capped`` fitness: ``min(combined, worst + CAP_MARGIN)``.
CAP_MARGIN = 0.05

_FOUR_SQRT3 = 4.0 * math.sqrt(3.0)
_DEG = 180.0 / math.pi
_MAX_ANGLE_ERROR = 21600.0  # (0-60)^2 + (0-60)^2 + (180-60)^2


@dataclass(frozen=True)
class Stars:
    """Stars of every node in compressed rows: node ``n`` owns entries ``ptr[n]:ptr[n+1]``."""

    ptr: IntArray  #: (n+1,) row starts
    tri: IntArray  #: (3m,) triangle of each entry
    opp_a: IntArray  #: (3m,) first other corner, counter-clockwise after the node
    opp_b: IntArray  #: (3m,) second other corner

    def neighbours(self, node: int) -> IntArray:
        """Nodes sharing a triangle with ``node`` (unsorted, without repeats)."""
        s = slice(self.ptr[node], self.ptr[node + 1])
        return np.unique(np.concatenate([self.opp_a[s], self.opp_b[s]]))


def build_stars(triangles: IntArray, n_points: int) -> Stars:
    """The stars of all ``n_points`` nodes of ``triangles`` (vectorised, O(m log m))."""
    t = np.asarray(triangles, dtype=np.int64)
    node = t.ravel()
    order = corner_order(node)  # stable: each star stays in triangle order
    tri = order // 3
    corner = order % 3
    ptr = np.zeros(n_points + 1, dtype=np.int64)
    np.cumsum(np.bincount(node, minlength=n_points), out=ptr[1:])
    opp_a = t[tri, (corner + 1) % 3]
    opp_b = t[tri, (corner + 2) % 3]
    return Stars(ptr=ptr, tri=tri.astype(np.int64), opp_a=opp_a, opp_b=opp_b)


@numba.njit(cache=True, inline="always")
def _corner(ux: float, uy: float, vx: float, vy: float) -> float:
    """Angle in degrees between u and v, as :func:`engine.quality.corner_angles` computes it."""
    return math.degrees(math.atan2(abs(ux * vy - uy * vx), ux * vx + uy * vy))


@numba.njit(cache=True, inline="always")
def _quality(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    """Signed shape quality of (p, a, b), as :func:`engine.quality.shape_quality` defines it."""
    s0 = (bx - ax) ** 2 + (by - ay) ** 2
    s1 = (px - bx) ** 2 + (py - by) ** 2
    s2 = (ax - px) ** 2 + (ay - py) ** 2
    area = 0.5 * ((ax - px) * (by - py) - (ay - py) * (bx - px))
    return _FOUR_SQRT3 * area / max(s0 + s1 + s2, 1e-300)


@numba.njit(cache=True)
def triangle_terms(
    px: float, py: float, ax: float, ay: float, bx: float, by: float
) -> tuple[float, float]:
    """Angle score and shape quality of the counter-clockwise triangle (p, a, b).

    The shape quality is signed (negative when inverted); the angle score is 0 when the quality
    is not positive, as in :func:`engine.fitness.triangle_scores`.
    """
    q = _quality(px, py, ax, ay, bx, by)
    if q <= 0.0:
        return 0.0, q
    t0 = _corner(ax - px, ay - py, bx - px, by - py)
    t1 = _corner(bx - ax, by - ay, px - ax, py - ay)
    t2 = _corner(px - bx, py - by, ax - bx, ay - by)
    err = (t0 - 60.0) ** 2 + (t1 - 60.0) ** 2 + (t2 - 60.0) ** 2
    return 1.0 - err / _MAX_ANGLE_ERROR, q


@numba.njit(cache=True, inline="always")
def combine(
    kind: int, angle: float, mean_q: float, worst: float, alpha: float, beta: float
) -> float:
    """The one dispatch on the fitness code: fitness ``kind`` of a star from its mean angle
    score, mean shape quality and worst shape quality (the star is admissible)."""
    if kind == ANGLE:
        return angle
    if kind == ASPECT:
        return mean_q
    combined = (alpha * angle + beta * mean_q) / (alpha + beta)
    if kind == COMBINED:
        return combined
    if kind == CAPPED:
        return min(combined, worst + CAP_MARGIN)
    return worst  # WORST


@numba.njit(cache=True)
def star_fitness(
    x: float,
    y: float,
    node: int,
    points: FloatArray,
    ptr: IntArray,
    opp_a: IntArray,
    opp_b: IntArray,
    kind: int,
    alpha: float,
    beta: float,
) -> float:
    """Fitness of ``node``'s star with the node placed at ``(x, y)``."""
    s_angle = 0.0
    s_q = 0.0
    worst = math.inf
    inverted = False
    count = ptr[node + 1] - ptr[node]
    for j in range(ptr[node], ptr[node + 1]):
        a, b = opp_a[j], opp_b[j]
        angle, q = triangle_terms(x, y, points[a, 0], points[a, 1], points[b, 0], points[b, 1])
        if q <= 0.0:
            inverted = True
        s_angle += angle
        s_q += q
        worst = min(worst, q)
    if count == 0 or inverted:
        return 0.0
    return combine(kind, s_angle / count, s_q / count, worst, alpha, beta)


@numba.njit(cache=True)
def star_min_quality(
    x: float,
    y: float,
    node: int,
    points: FloatArray,
    ptr: IntArray,
    opp_a: IntArray,
    opp_b: IntArray,
) -> float:
    """Smallest signed shape quality of ``node``'s star with the node at ``(x, y)``."""
    worst = math.inf
    for j in range(ptr[node], ptr[node + 1]):
        a, b = opp_a[j], opp_b[j]
        worst = min(worst, _quality(x, y, points[a, 0], points[a, 1], points[b, 0], points[b, 1]))
    return worst


@numba.njit(cache=True)
def all_fitness(
    points: FloatArray,
    ptr: IntArray,
    opp_a: IntArray,
    opp_b: IntArray,
    kind: int,
    alpha: float,
    beta: float,
) -> FloatArray:
    """Fitness of every node at its current position."""
    n = len(ptr) - 1
    out = np.empty(n)
    for node in range(n):
        out[node] = star_fitness(
            points[node, 0], points[node, 1], node, points, ptr, opp_a, opp_b, kind, alpha, beta
        )
    return out


@numba.njit(cache=True)
def star_min_qualities(
    nodes: IntArray, points: FloatArray, ptr: IntArray, opp_a: IntArray, opp_b: IntArray
) -> FloatArray:
    """Worst shape quality of each node's star, at the current positions."""
    out = np.empty(len(nodes))
    for i in range(len(nodes)):
        n = nodes[i]
        out[i] = star_min_quality(points[n, 0], points[n, 1], n, points, ptr, opp_a, opp_b)
    return out


@numba.njit(cache=True)
def mark_neighbours(
    nodes: IntArray, ptr: IntArray, opp_a: IntArray, opp_b: IntArray, flags: NDArray[np.bool_]
) -> None:
    """Set ``flags`` of ``nodes`` and of every node sharing a triangle with one of them."""
    for i in range(len(nodes)):
        n = nodes[i]
        flags[n] = True
        for j in range(ptr[n], ptr[n + 1]):
            flags[opp_a[j]] = True
            flags[opp_b[j]] = True
