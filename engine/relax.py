"""Constrained Laplacian relaxation: the advancing front's finishing step.

Each free node moves toward the centroid of its neighbours (full step, else half a step) only if
the worst triangle of its star does not get worse, so no triangle inverts and the worst element
never degrades. A few Gauss-Seidel sweeps even out the seams where fronts met, as Gmsh's
meshers smooth their output by default.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba as nb
import numpy as np
from numpy.typing import NDArray

from .errors import Cancelled
from .mesh import Mesh, corner_order
from .quality import radius_ratio, shape_quality
from .result import StopFn

__all__ = ["MeanLimits", "node_stars", "radius_ratio_xy", "relax", "relax_mean"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Nodes whose worst star triangle is below this quality also try the targeted move.
TARGETED_BELOW = 0.8
COMPASS_ITERATIONS = 12
#: :func:`relax_mean` moves a node only for at least this gain in its star's summed radius ratio.
MEAN_GAIN = 1e-4
#: Sweeps of :func:`relax_mean`: six keep the default pipeline within gmsh's time with a
#: margin (spiral at 0.92 of gmsh's CPU time; eight: 0.98) for most of eight's gain in the mean
#: (spiral 0.99132 -> 0.99291 in 19 ms; eight: 0.99296 in 23 ms).
MEAN_SWEEPS = 6
#: :func:`relax_mean` lets a star's worst radius ratio fall to this (or to the mesh's worst,
#: when higher), never lower.
MEAN_FLOOR = 0.8
#: Gradient-ascent steps of :func:`relax_mean` after its centroid trial ...
MEAN_ITERATIONS = 2
#: ... at nodes whose star's worst radius ratio is below this.
MEAN_BELOW = 0.95
#: The compass directions of the targeted move (the values ``math.cos(d * pi / 4)`` gives).
_COS = np.array([math.cos(d * math.pi / 4.0) for d in range(8)])
_SIN = np.array([math.sin(d * math.pi / 4.0) for d in range(8)])


def node_stars(triangles: IntArray, n_points: int) -> tuple[IntArray, IntArray]:
    """CSR of the triangles around each node: ``tri_of[start[v]:start[v + 1]]``, each star in
    triangle order.

    >>> start, tri_of = node_stars(np.array([[0, 1, 2], [0, 2, 3]]), 4)
    >>> start.tolist(), tri_of.tolist()
    ([0, 2, 3, 5, 6], [0, 1, 0, 0, 1, 1])
    """
    flat = np.ascontiguousarray(triangles, dtype=np.int64).ravel()
    counts = np.bincount(flat, minlength=n_points)
    start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return start, corner_order(flat) // 3


@nb.njit(cache=True, inline="always")
def _q(p: FloatArray, t: IntArray, tr: int) -> float:
    ax, ay = p[t[tr, 0], 0], p[t[tr, 0], 1]
    bx, by = p[t[tr, 1], 0], p[t[tr, 1], 1]
    cx, cy = p[t[tr, 2], 0], p[t[tr, 2], 1]
    area2 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    s = (bx - ax) ** 2 + (by - ay) ** 2 + (cx - bx) ** 2 + (cy - by) ** 2 + (ax - cx) ** 2
    s += (ay - cy) ** 2
    return 2.0 * math.sqrt(3.0) * area2 / s


@nb.njit(cache=True)
def _relax(
    p: FloatArray, t: IntArray, fixed: BoolArray, start: IntArray, tri_of: IntArray, sweeps: int
) -> int:  # pragma: no cover - compiled
    moved = 0
    for _ in range(sweeps):
        for v in range(p.shape[0]):
            if fixed[v] or start[v + 1] == start[v]:
                continue
            sx, sy, cnt, worst = 0.0, 0.0, 0, np.inf
            for k in range(start[v], start[v + 1]):
                tr = tri_of[k]
                for j in range(3):
                    w = t[tr, j]
                    if w != v:
                        sx += p[w, 0]
                        sy += p[w, 1]
                        cnt += 1
                worst = min(worst, _q(p, t, tr))
            ox, oy = p[v, 0], p[v, 1]
            tx, ty = sx / cnt - ox, sy / cnt - oy
            done = False
            for step in (1.0, 0.5):
                p[v, 0], p[v, 1] = ox + step * tx, oy + step * ty
                new_worst = _star_worst(p, t, start, tri_of, v, worst)
                if new_worst >= worst and new_worst > 0.0:
                    moved += 1
                    done = True
                    break
                p[v, 0], p[v, 1] = ox, oy
            if done or worst >= TARGETED_BELOW:
                continue
            # The centroid does not help the worst triangle: a compass search that maximises the
            # star's worst quality (steps shrink from a third of the shortest star edge).
            best = worst
            step = _shortest_edge(p, t, start, tri_of, v) / 3.0
            bx, by = ox, oy
            for _ in range(COMPASS_ITERATIONS):
                improved = False
                for d in range(8):
                    p[v, 0] = bx + step * _COS[d]
                    p[v, 1] = by + step * _SIN[d]
                    q = _star_worst(p, t, start, tri_of, v, best)
                    if q > best:
                        best, nbx, nby, improved = q, p[v, 0], p[v, 1], True
                if improved:
                    bx, by = nbx, nby
                else:
                    step *= 0.5
            p[v, 0], p[v, 1] = bx, by
            if best > worst:
                moved += 1
    return moved


@nb.njit(cache=True, inline="always")
def _star_worst(
    p: FloatArray, t: IntArray, start: IntArray, tri_of: IntArray, v: int, floor: float
) -> float:
    """Worst quality around ``v``, or any value below ``floor`` once the worst is known to
    be below it (the callers only compare it with ``floor``)."""
    worst = np.inf
    for k in range(start[v], start[v + 1]):
        worst = min(worst, _q(p, t, tri_of[k]))
        if worst < floor:
            return worst
    return worst


@nb.njit(cache=True)
def _shortest_edge(
    p: FloatArray, t: IntArray, start: IntArray, tri_of: IntArray, v: int
) -> float:  # pragma: no cover - compiled
    out = np.inf
    for k in range(start[v], start[v + 1]):
        tr = tri_of[k]
        for j in range(3):
            w = t[tr, j]
            if w != v:
                out = min(out, math.hypot(p[w, 0] - p[v, 0], p[w, 1] - p[v, 1]))
    return out


def relax(
    mesh: Mesh,
    sweeps: int = 3,
    fixed: BoolArray | None = None,
    should_stop: StopFn | None = None,
) -> Mesh:
    """The mesh after ``sweeps`` of constrained relaxation (boundary nodes fixed).

    ``should_stop()`` is polled before each sweep (:class:`Cancelled` when true).

    >>> pts = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1], [0.9, 0.8]])
    >>> tris = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    >>> relax(Mesh(pts, tris)).points[4].round(3).tolist()
    [0.5, 0.5]
    """
    points = mesh.points.copy()
    if sweeps <= 0 or mesh.n_triangles == 0:
        return Mesh(points, mesh.triangles)
    mask = mesh.boundary_nodes if fixed is None else fixed
    start, tri_of = node_stars(mesh.triangles, mesh.n_points)
    for _ in range(sweeps):  # one sweep a call: the sweeps share no state
        if should_stop is not None and should_stop():
            raise Cancelled("stopped while relaxing the mesh")
        _relax(points, mesh.triangles, np.ascontiguousarray(mask), start, tri_of, 1)
    return mesh.with_points(points)


@nb.njit(cache=True, inline="always")
def radius_ratio_xy(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    """Radius ratio ``2r/R`` of one triangle, negative when it is clockwise (compiled kernels)."""
    area = 0.5 * ((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))
    a = math.hypot(bx - ax, by - ay)
    b = math.hypot(cx - bx, cy - by)
    c = math.hypot(ax - cx, ay - cy)
    # 2r/R = 8 A^2 / (s a b c) with s the half perimeter.
    return 16.0 * area * abs(area) / max((a + b + c) * a * b * c, 1e-300)


@nb.njit(cache=True, inline="always")
def _star_rr(
    p: FloatArray, t: IntArray, start: IntArray, tri_of: IntArray, v: int
) -> tuple[float, float, float]:
    """Worst and summed radius ratio, and worst shape quality, of the triangles around ``v``."""
    worst, total, shape = np.inf, 0.0, np.inf
    for k in range(start[v], start[v + 1]):
        a, b, c = t[tri_of[k], 0], t[tri_of[k], 1], t[tri_of[k], 2]
        q = radius_ratio_xy(p[a, 0], p[a, 1], p[b, 0], p[b, 1], p[c, 0], p[c, 1])
        worst, total, shape = min(worst, q), total + q, min(shape, _q(p, t, tri_of[k]))
    return worst, total, shape


class MeanLimits(NamedTuple):
    """What :func:`relax_mean`'s kernel may do to a star (a named tuple: numba takes it whole)."""

    #: Lowest worst radius ratio and shape quality a star may fall to (unless already lower).
    floor: float
    shape_floor: float
    #: Gradient-ascent steps after the centroid trial (0: the centroid trial alone) ...
    iterations: int
    #: ... for nodes whose star's worst radius ratio is below this.
    below: float


@nb.njit(cache=True, inline="always")
def _allowed(new: tuple[float, float, float], least: float, least_shape: float) -> bool:
    return new[0] >= least and new[2] >= least_shape and new[0] > 0.0


@nb.njit(cache=True)
def _ascent(
    p: FloatArray, t: IntArray, start: IntArray, tri_of: IntArray, v: int, total: float,
    least: float, least_shape: float, iterations: int,
) -> float:  # fmt: skip  # pragma: no cover - compiled
    """Move ``v`` up the gradient of its star's summed radius ratio (a difference quotient,
    then the longest of a fifth, tenth, twentieth or fortieth of the shortest star edge that
    raises the sum within the floors); returns the new sum."""
    edge = _shortest_edge(p, t, start, tri_of, v)
    eps = 1e-4 * edge
    for _ in range(iterations):
        ox, oy = p[v, 0], p[v, 1]
        p[v, 0] = ox + eps
        gx = _star_rr(p, t, start, tri_of, v)[1] - total
        p[v, 0], p[v, 1] = ox, oy + eps
        gy = _star_rr(p, t, start, tri_of, v)[1] - total
        norm = math.hypot(gx, gy)
        p[v, 0], p[v, 1] = ox, oy
        if norm == 0.0:
            break
        improved = False
        for share in (0.2, 0.1, 0.05, 0.025):
            p[v, 0] = ox + share * edge * gx / norm
            p[v, 1] = oy + share * edge * gy / norm
            new = _star_rr(p, t, start, tri_of, v)
            if new[1] > total and _allowed(new, least, least_shape):
                total, improved = new[1], True
                break
        if not improved:
            p[v, 0], p[v, 1] = ox, oy
            break
    return total


@nb.njit(cache=True)
def _relax_mean(
    p: FloatArray, t: IntArray, active: BoolArray, start: IntArray, tri_of: IntArray,
    limits: MeanLimits,
) -> BoolArray:  # fmt: skip  # pragma: no cover - compiled
    """One sweep over the ``active`` nodes; returns the nodes of the stars that moved."""
    woken = np.zeros(p.shape[0], dtype=np.bool_)
    for v in range(p.shape[0]):
        if not active[v] or start[v + 1] == start[v]:
            continue
        sx, sy, cnt = 0.0, 0.0, 0
        for k in range(start[v], start[v + 1]):
            for j in range(3):
                w = t[tri_of[k], j]
                if w != v:
                    sx, sy, cnt = sx + p[w, 0], sy + p[w, 1], cnt + 1
        worst, total, shape = _star_rr(p, t, start, tri_of, v)
        least, least_shape = min(worst, limits.floor), min(shape, limits.shape_floor)
        ox, oy = p[v, 0], p[v, 1]
        tx, ty = sx / cnt - ox, sy / cnt - oy
        gained = total
        for step in (1.0, 0.5, 0.25):
            p[v, 0], p[v, 1] = ox + step * tx, oy + step * ty
            new = _star_rr(p, t, start, tri_of, v)
            if new[1] > total + MEAN_GAIN and _allowed(new, least, least_shape):
                gained = new[1]
                break
            p[v, 0], p[v, 1] = ox, oy
        if limits.iterations > 0 and worst < limits.below:
            # The centroid is a guess: a short search finds the sum's maximum nearby.
            cx, cy = p[v, 0], p[v, 1]
            searched = _ascent(
                p, t, start, tri_of, v, gained, least, least_shape, limits.iterations
            )
            if searched > total + MEAN_GAIN:
                gained = searched
            else:
                p[v, 0], p[v, 1] = cx, cy
        if gained > total + MEAN_GAIN:
            for k in range(start[v], start[v + 1]):
                for j in range(3):
                    woken[t[tri_of[k], j]] = True
    return woken


def relax_mean(
    mesh: Mesh,
    sweeps: int = MEAN_SWEEPS,
    floor: float = MEAN_FLOOR,
    iterations: int = MEAN_ITERATIONS,
    below: float = MEAN_BELOW,
) -> Mesh:
    """The mesh after ``sweeps`` of relaxation for the mean radius ratio (boundary fixed).

    Each free node moves toward the centroid of its neighbours (a full, half or quarter step)
    when that raises the summed radius ratio of its star and the star's worst stays at least
    the lower of its old worst and ``max(floor, the mesh's worst)``, in radius ratio and in
    shape quality alike: the mesh's worst triangle never gets worse by either measure, while a
    star well above it may give a little of its worst for its mean (:func:`relax` never gives
    any, and leaves graded bands below gmsh's mean). At a node whose star's worst is below
    ``below`` up to ``iterations`` gradient-ascent steps on that sum follow (the centroid is only
    a guess at its maximum), under the same floors. After the first sweep only nodes next to
    one that moved are looked at again.

    >>> pts = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1], [0.8, 0.7]])
    >>> tris = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    >>> relax_mean(Mesh(pts, tris)).points[4].round(3).tolist()
    [0.5, 0.5]
    """
    points = mesh.points.copy()
    if sweeps <= 0 or mesh.n_triangles == 0:
        return Mesh(points, mesh.triangles)
    start, tri_of = node_stars(mesh.triangles, mesh.n_points)
    free = ~mesh.boundary_nodes
    active = free.copy()
    for _ in range(sweeps):
        if not active.any():
            break
        # The floors follow the mesh's worst as it rises: a worst lifted by one sweep is kept.
        worst = float(radius_ratio(points, mesh.triangles).min())
        worst_shape = float(shape_quality(points, mesh.triangles).min())
        limits = MeanLimits(max(floor, worst), max(floor, worst_shape), iterations, below)
        # After the first sweep only nodes next to one that moved are looked at again.
        active = _relax_mean(points, mesh.triangles, active, start, tri_of, limits) & free
    return Mesh(points, mesh.triangles)
