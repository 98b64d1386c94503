"""Laplacian baselines: ``laplacian`` and ``smart-laplacian`` (registry names).

Both move each interior node, in node order (Gauss-Seidel), to the centroid of its neighbours,
for ``iterations`` sweeps or until no node moves; boundary nodes stay fixed.

- ``laplacian``: the plain method, with one guard: a move that would invert or flatten a
  triangle of the star (shape quality at or below :data:`engine.star.MIN_QUALITY`) is skipped, so
  the result is always a valid mesh; it may still lower the quality of any triangle.
- ``smart-laplacian``: a move is kept only if it inverts nothing and does not lower the worst
  shape quality of the node's star.
"""

from __future__ import annotations

import time

import numba
import numpy as np
from numpy.typing import NDArray

from .errors import Cancelled
from .fitness import fitness_code
from .mesh import Mesh
from .params import SmoothingParams
from .result import ProgressFn, SmoothOutcome, StopFn, SweepStats
from .star import MIN_QUALITY, all_fitness, build_stars, star_min_quality

__all__ = ["laplacian_smooth", "smart_laplacian_smooth"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@numba.njit(cache=True)
def laplacian_sweep(
    nodes: IntArray,
    points: FloatArray,
    ptr: IntArray,
    opp_a: IntArray,
    opp_b: IntArray,
    smart: bool,
) -> int:
    """One Gauss-Seidel sweep over interior ``nodes``; returns how many moved."""
    moved = 0
    for i in range(len(nodes)):
        n = nodes[i]
        j0, j1 = ptr[n], ptr[n + 1]
        if j1 == j0:
            continue
        sx, sy = 0.0, 0.0
        for j in range(j0, j1):  # an interior node's neighbours are its opp_a, once each
            sx += points[opp_a[j], 0]
            sy += points[opp_a[j], 1]
        x, y = sx / (j1 - j0), sy / (j1 - j0)
        if x == points[n, 0] and y == points[n, 1]:
            continue
        worst = star_min_quality(x, y, n, points, ptr, opp_a, opp_b)
        if worst <= MIN_QUALITY:
            continue  # the step would flip or flatten a triangle
        if smart and worst < star_min_quality(
            points[n, 0], points[n, 1], n, points, ptr, opp_a, opp_b
        ):
            continue
        points[n, 0], points[n, 1] = x, y
        moved += 1
    return moved


def _laplacian(
    mesh: Mesh,
    params: SmoothingParams,
    progress: ProgressFn,
    should_stop: StopFn,
    smart: bool,
) -> SmoothOutcome:
    kind = fitness_code(params.fitness)
    s = build_stars(mesh.triangles, mesh.n_points)
    points = np.array(mesh.points, dtype=np.float64, order="C")
    movable = ~mesh.boundary_nodes
    nodes = np.flatnonzero(movable).astype(np.int64)
    alpha, beta = float(params.alpha), float(params.beta)
    fitness = all_fitness(points, s.ptr, s.opp_a, s.opp_b, kind, alpha, beta)
    history: list[SweepStats] = []
    for it in range(1, params.iterations + 1):
        if should_stop():
            raise Cancelled("smoothing stopped between Laplacian sweeps")
        t0 = time.perf_counter()
        moved = laplacian_sweep(nodes, points, s.ptr, s.opp_a, s.opp_b, smart)
        after = all_fitness(points, s.ptr, s.opp_a, s.opp_b, kind, alpha, beta)
        inner = after[movable]
        history.append(
            SweepStats(
                sweep=it,
                mean_fitness=float(inner.mean()) if inner.size else 0.0,
                min_fitness=float(inner.min()) if inner.size else 0.0,
                max_change=float(np.abs(after - fitness).max()),
                nodes_evolved=len(nodes),
                nodes_moved=moved,
                seconds=time.perf_counter() - t0,
            )
        )
        fitness = after
        progress("smooth", it / params.iterations)
        if moved == 0:
            break
    return SmoothOutcome(points=points, history=tuple(history))


def laplacian_smooth(
    mesh: Mesh,
    params: SmoothingParams,
    rng: np.random.Generator,
    progress: ProgressFn,
    should_stop: StopFn,
) -> SmoothOutcome:
    """Plain Laplacian smoothing (guarded against inversion); ``rng`` is unused.

    >>> pts = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [0.3, 1.6]])
    >>> tri = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    >>> out = laplacian_smooth(Mesh(pts, tri), SmoothingParams(), np.random.default_rng(0),
    ...                        lambda stage, f: None, lambda: False)
    >>> out.points[4].tolist(), len(out.history)
    ([1.0, 1.0], 2)
    """
    del rng
    return _laplacian(mesh, params, progress, should_stop, smart=False)


def smart_laplacian_smooth(
    mesh: Mesh,
    params: SmoothingParams,
    rng: np.random.Generator,
    progress: ProgressFn,
    should_stop: StopFn,
) -> SmoothOutcome:
    """Smart Laplacian smoothing: keep a move only if the star's worst quality does not drop."""
    del rng
    return _laplacian(mesh, params, progress, should_stop, smart=True)
