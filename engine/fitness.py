"""Per-node fitness: how good the star of triangles around a node is, in [0, 1].

Definitions (a node's *star* is the set of triangles that use it):

- ``angle``: for each triangle of the star, ``1 - sum_k (theta_k - 60)^2 / 21600`` with the three
  interior angles in degrees (21600 = the largest possible sum, reached by a flat 0/0/180
  triangle); the node's term is the mean over the star. 1 means all equilateral.
- ``aspect``: mean over the star of the shape quality ``4*sqrt(3)*A / (l1^2 + l2^2 + l3^2)``.
- ``combined``: ``(alpha * angle + beta * aspect) / (alpha + beta)`` (the paper's 0.8 / 0.2).
- ``worst``: the smallest shape quality in the star.
- ``capped``: ``min(combined, worst + 0.05)``. Not in the paper, and the default because it
  measured best (README, "Smoothing"): a node whose star holds a triangle much worse than the
  star's average works on that triangle (as ``worst`` does), every other node on the paper's
  ``combined``. ``combined`` alone leaves the worst triangles behind even the smart Laplacian;
  ``worst`` alone lifts them but lowers the mean quality.

A star with an inverted or degenerate triangle has fitness 0, and so has a node used by no
triangle.

The numpy functions in :data:`REFERENCE` state these definitions plainly; :data:`FITNESS` (what
:func:`node_fitness`, the reports and every smoother use) computes the same values with the numba
kernels of :mod:`engine.star`, which agree with the reference to rounding (the tests hold them
to 1e-12).

Adding a fitness: a row in :data:`engine.star.FITNESS_KINDS`, its formula in
:func:`engine.star.combine` (the one place the kernels dispatch on a fitness; the exact kernels
and the GA's guide both call it), and its plain statement in :data:`REFERENCE`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from . import star
from .mesh import Mesh
from .quality import corner_angles, shape_quality

__all__ = [
    "FITNESS",
    "FITNESS_CODES",
    "REFERENCE",
    "fitness_code",
    "node_fitness",
    "star_min",
    "triangle_scores",
]

FloatArray = NDArray[np.float64]
_MAX_ANGLE_ERROR = 21600.0  # (0-60)^2 + (0-60)^2 + (180-60)^2


def triangle_scores(mesh: Mesh) -> tuple[FloatArray, FloatArray]:
    """Per-triangle angle score and shape quality (both 0 for inverted triangles)."""
    p, t = mesh.points, mesh.triangles
    q = shape_quality(p, t)
    err = ((corner_angles(p, t) - 60.0) ** 2).sum(axis=1)
    angle = np.where(q > 0, 1.0 - err / _MAX_ANGLE_ERROR, 0.0)
    return angle, np.maximum(q, 0.0)


def _star_mean(mesh: Mesh, per_triangle: FloatArray) -> FloatArray:
    n = mesh.n_points
    total = np.zeros(n)
    count = np.zeros(n)
    for k in range(3):
        np.add.at(total, mesh.triangles[:, k], per_triangle)
        np.add.at(count, mesh.triangles[:, k], 1.0)
    return np.where(count > 0, total / np.maximum(count, 1.0), 0.0)


def star_min(mesh: Mesh, per_triangle: FloatArray) -> FloatArray:
    """Per node, the smallest ``per_triangle`` value of its star (0 for a node in none)."""
    out = np.full(mesh.n_points, np.inf)
    for k in range(3):
        np.minimum.at(out, mesh.triangles[:, k], per_triangle)
    return np.where(np.isfinite(out), out, 0.0)


def _inverted_stars(mesh: Mesh, q: FloatArray) -> NDArray[np.bool_]:
    bad = np.zeros(mesh.n_points, dtype=bool)
    bad[mesh.triangles[q <= 0].ravel()] = True
    return bad


def angle_fitness(mesh: Mesh, alpha: float = 0.8, beta: float = 0.2) -> FloatArray:
    angle, q = triangle_scores(mesh)
    return np.where(_inverted_stars(mesh, q), 0.0, _star_mean(mesh, angle))


def aspect_fitness(mesh: Mesh, alpha: float = 0.8, beta: float = 0.2) -> FloatArray:
    _, q = triangle_scores(mesh)
    return np.where(_inverted_stars(mesh, q), 0.0, _star_mean(mesh, q))


def combined_fitness(mesh: Mesh, alpha: float = 0.8, beta: float = 0.2) -> FloatArray:
    angle, q = triangle_scores(mesh)
    value = (alpha * _star_mean(mesh, angle) + beta * _star_mean(mesh, q)) / (alpha + beta)
    return np.where(_inverted_stars(mesh, q), 0.0, value)


def worst_fitness(mesh: Mesh, alpha: float = 0.8, beta: float = 0.2) -> FloatArray:
    _, q = triangle_scores(mesh)
    return np.where(_inverted_stars(mesh, q), 0.0, star_min(mesh, q))


def capped_fitness(mesh: Mesh, alpha: float = 0.8, beta: float = 0.2) -> FloatArray:
    worst = worst_fitness(mesh, alpha, beta)
    combined = combined_fitness(mesh, alpha, beta)
    return np.minimum(combined, worst + star.CAP_MARGIN)


FitnessFn = Callable[[Mesh, float, float], FloatArray]

#: The plain numpy statement of each fitness: ``fn(mesh, alpha, beta) -> (n,)``.
REFERENCE: dict[str, FitnessFn] = {
    "angle": angle_fitness,
    "aspect": aspect_fitness,
    "combined": combined_fitness,
    "worst": worst_fitness,
    "capped": capped_fitness,
}

#: The kernels' code of each fitness name (:data:`engine.star.FITNESS_KINDS`, where a fitness
#: is added).
FITNESS_CODES: dict[str, int] = {name: code for code, (name, _) in enumerate(star.FITNESS_KINDS)}


def fitness_code(name: str) -> int:
    """The kernel code of fitness ``name``; ``ValueError`` naming the choices when unknown.

    >>> fitness_code("worst") == star.WORST
    True
    """
    try:
        return FITNESS_CODES[name]
    except KeyError:
        raise ValueError(
            f"unknown fitness {name!r}; choose one of {sorted(FITNESS_CODES)}"
        ) from None


def _kernel_fitness(code: int) -> FitnessFn:
    def fitness(mesh: Mesh, alpha: float = 0.8, beta: float = 0.2) -> FloatArray:
        s = star.build_stars(mesh.triangles, mesh.n_points)
        pts = np.ascontiguousarray(mesh.points, dtype=np.float64)
        return star.all_fitness(pts, s.ptr, s.opp_a, s.opp_b, code, float(alpha), float(beta))

    return fitness


#: Node fitness functions by name: ``fn(mesh, alpha, beta) -> (n,)``, computed by the kernels.
FITNESS: dict[str, FitnessFn] = {
    name: _kernel_fitness(code) for name, code in FITNESS_CODES.items()
}


def node_fitness(
    mesh: Mesh, name: str = "capped", alpha: float = 0.8, beta: float = 0.2
) -> FloatArray:
    """Fitness of every node of ``mesh`` by the named function.

    >>> eq = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    >>> node_fitness(Mesh(eq, np.array([[0, 1, 2]]))).round(6).tolist()
    [1.0, 1.0, 1.0]
    """
    return FITNESS[_known(name)](mesh, alpha, beta)


def _known(name: str) -> str:
    fitness_code(name)
    return name
