"""Split triangles that span a wedge: a node for the triangles whose corners are all fixed.

Near a sharp input corner the front fills the wedge with a ladder of triangles whose three nodes
all lie on the boundary: relaxation and the smoother cannot move them, swapping only re-pairs
them. A ladder rung across a theta-wedge has an angle of ``180 - (180 - theta) / 2`` at its foot
(105 degrees at 30), which caps its radius ratio at 0.655 whatever the node spacing, while the
corner's own triangle reaches 0.767. Each such triangle worse than the worst triangle holding an
input corner whole (nothing can lift that one) is offered a new interior node joined to the
corners of a small cavity: the triangle alone, with one neighbour across an interior side, with
all its interior neighbours, or three triangles in a row. The node goes where the worst radius
ratio of its fan is best (compass search); the best cavity is refilled when that beats the
cavity's old worst by :data:`GAIN`, no angle falls below min(the cavity's smallest, 30), so an
input corner's angle is split only where both halves stay above the bound min(corner, 30), and
swapping would not flip a side of it to join the node to a corner beyond.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Collection

import numba as nb
import numpy as np
from numpy.typing import NDArray

from .mesh import Mesh
from .quality import min_angle, radius_ratio, shape_quality
from .sides import _HALVINGS, _THIRTY, _cavities, _fan, split_sides_round
from .swap import _neighbours

__all__ = ["split_spanning"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Triangles with all three nodes on the boundary below this radius ratio are candidates.
SPLIT_BELOW = 0.85
#: A cavity is refilled only when its worst triangle gains this much (relative).
GAIN = 0.02
#: Passes of :func:`split_spanning`.
ROUNDS = 3
#: Swapping's margin (:data:`engine.swap._MARGIN` or more): flips it would make.
_SWAP_MARGIN = 1e-9


@nb.njit(cache=True)
def _place(
    p: FloatArray, ring: IntArray
) -> tuple[float, float, float, float, float]:  # pragma: no cover - compiled
    """Where a node inside ``ring`` makes the worst fan triangle best: (x, y, the fan's worst
    and mean radius ratio, its smallest angle)."""
    k = ring.shape[0]
    x, y, step = 0.0, 0.0, 0.0
    for i in range(k):
        x += p[ring[i], 0] / k
        y += p[ring[i], 1] / k
    for i in range(k):
        j = ring[(i + 1) % k]
        step += math.hypot(p[j, 0] - p[ring[i], 0], p[j, 1] - p[ring[i], 1]) / (4.0 * k)
    worst, mean, smallest = _fan(p, ring, x, y, k)
    for _ in range(_HALVINGS):
        moved = True
        while moved:
            moved = False
            for d in range(8):
                a = d * math.pi / 4.0
                cx, cy = x + step * math.cos(a), y + step * math.sin(a)
                w, m, a = _fan(p, ring, cx, cy, k)
                if w > worst:
                    x, y, worst, mean, smallest, moved = cx, cy, w, m, a, True
        step *= 0.5
    return x, y, worst, mean, smallest


def _chains(tri: IntArray, nbr: IntArray, t: int) -> list[tuple[list[int], list[int]]]:
    """Cavities of three triangles in a row from ``t`` (``t``, a neighbour, one of its other
    neighbours) that form a disc without inner nodes: (triangles, corners counter-clockwise).

    In a coarse wedge the rung after the corner's triangle has only the next rung beside it,
    and a node in those two alone leaves a flat fan triangle on the longer rung (0.65 at 36
    degrees); the triangle beyond the next rung gives the node room.
    """
    out = []
    for n in nbr[t].tolist():
        if n < 0:
            continue
        for m in nbr[n].tolist():
            if m < 0 or m == t:
                continue
            ring = _ring(tri, [t, n, m])
            if ring is not None:
                out.append(([t, n, m], ring))
    return out


def _swapped_into_corner(
    p: FloatArray,
    tri: IntArray,
    nbr: IntArray,
    tris: list[int],
    xy: tuple[float, float],
    least: float,
) -> bool:
    """Whether diagonal swapping (:func:`engine.swap.swap_diagonals`, by shape quality) would
    flip a side of the cavity ``tris`` refilled around ``xy`` to join the new node to the far
    corner of the triangle beyond, leaving an angle below ``least`` (radians).

    In a coarse wedge (7 triangles) the fan beside the corner's triangle is worse than the two
    triangles that halve the corner, so swapping split a 56-degree corner into 28-degree ones.
    """
    inside = set(tris)
    for u in tris:
        for k in range(3):
            n = int(nbr[u, k])
            if n < 0 or n in inside:
                continue
            a, b = int(tri[u, (k + 1) % 3]), int(tri[u, (k + 2) % 3])
            c = next(int(v) for v in tri[n] if v != a and v != b)
            pts = np.array([p[a], p[b], p[c], xy])
            before = shape_quality(pts, np.array([[0, 1, 3], [1, 0, 2]])).min()
            flipped = np.array([[0, 2, 3], [2, 1, 3]])
            after = shape_quality(pts, flipped)
            flips = after.min() > before * (1.0 + _SWAP_MARGIN) and after.min() > 0.0
            if flips and np.radians(min_angle(pts, flipped).min()) < least:
                return True
    return False


def _ring(tri: IntArray, tris: list[int]) -> list[int] | None:
    """The corners counter-clockwise of the triangles ``tris`` when they form a disc with no
    node inside; None otherwise."""
    sides = {
        (int(a), int(b)) for t in tris for a, b in zip(tri[t], np.roll(tri[t], -1), strict=True)
    }
    after = {a: b for a, b in sides if (b, a) not in sides}
    if len(after) != len(tris) + 2 or len(set(after.values())) != len(after):
        return None
    ring = [min(after)]
    while len(ring) <= len(after) and after.get(ring[-1], ring[0]) != ring[0]:
        ring.append(after[ring[-1]])
    return ring if len(ring) == len(after) else None


def split_spanning(
    mesh: Mesh,
    rounds: int = ROUNDS,
    *,
    sides: bool = True,
    held: Collection[tuple[float, float, float, float]] = (),
) -> Mesh:
    """``mesh`` with a new node in each wedge-spanning triangle where that helps.

    Up to ``rounds`` passes: a cavity is taken by one triangle a pass, so a neighbour whose best
    cavity overlapped it tries again around the new node. Each pass first splits boundary
    sides (:func:`split_sides_round`; none when ``sides`` is false, and never a side in
    ``held``, given by its ends' coordinates ``(ax, ay, bx, by)`` either way: a subdomain's
    sides shared with a neighbour), then adds interior nodes.

    A 30-degree wedge: the corner's triangle, a rung (radius ratio 0.641) and two more. An
    interior node alone lifts the rung's cavity to 0.655; with nodes on the sides the worst is
    the isosceles corner triangle's 0.767, the best a triangle holding that corner can have.

    >>> from engine.quality import radius_ratio
    >>> side = np.array([np.cos(np.pi / 6), np.sin(np.pi / 6)])
    >>> pts = np.array([[0.0, 0], [1, 0], [1.67, 0], 1.67 * side, side, [2.5, 0]])
    >>> tris = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [2, 5, 3]])
    >>> for sides in (False, True):
    ...     out = split_spanning(Mesh(pts, tris), sides=sides)
    ...     print(out.n_points, round(float(radius_ratio(out.points, out.triangles).min()), 3))
    7 0.655
    9 0.767
    """
    if not sides:
        return _passes(mesh, rounds, (_split_round,))[0]
    sides_round = functools.partial(split_sides_round, held=frozenset(held))
    both, split_sides = _passes(mesh, rounds, (sides_round, _split_round))
    if not split_sides:
        return both
    plain, _ = _passes(mesh, rounds, (_split_round,))
    # A side split is kept by its cavity's figures, but it can take a cavity from a better
    # interior node (a 25.6-degree wedge ended at 0.645 with it, 0.689 without): keep the
    # whole pass only where the mesh's smallest angle (up to 30) or its worst gains.
    return both if _figures(both) >= _figures(plain) else plain


Step = Callable[[Mesh], "Mesh | None"]


def _passes(mesh: Mesh, rounds: int, steps: tuple[Step, ...]) -> tuple[Mesh, bool]:
    """``mesh`` after up to ``rounds`` passes of ``steps``, and whether the first step (the
    side splits, where given) changed it."""
    first = False
    for _ in range(rounds):
        changed = False
        for i, step in enumerate(steps):
            split = step(mesh)
            if split is not None:
                mesh, changed = split, True
                first = first or (i == 0 and len(steps) > 1)
        if not changed:
            break
    return mesh, first


def _figures(mesh: Mesh) -> tuple[float, float]:
    """The mesh's smallest angle (degrees, up to 30, to a tenth) and worst radius ratio."""
    p, tri = mesh.points, mesh.triangles
    return round(min(float(min_angle(p, tri).min()), 30.0), 1), float(radius_ratio(p, tri).min())


def _split_round(mesh: Mesh) -> Mesh | None:
    """One pass of :func:`split_spanning`; None when nothing was split."""
    if mesh.n_triangles == 0:
        return None
    tri, p = mesh.triangles, mesh.points
    # Only triangles with all three nodes on the boundary are looked at (the radius ratio of
    # the others is never needed; the boundary mask is cached for the relaxation that follows).
    spanning = mesh.boundary_nodes[tri].all(axis=1)
    if not spanning.any():
        return None
    q = np.full(len(tri), np.inf)
    q[spanning] = radius_ratio(p, tri[spanning])
    valence = np.bincount(tri.ravel(), minlength=mesh.n_points)
    # A triangle holding a node of valence one (always a spanning one) keeps that input
    # corner's angle whatever is done around it: splitting triangles already better than the
    # worst of those would add triangles (and lower the mean) without lifting the worst.
    cornered = (valence[tri] == 1).any(axis=1)
    floor = min(SPLIT_BELOW, float(q[cornered].min())) if cornered.any() else SPLIT_BELOW
    candidates = np.flatnonzero(spanning & (q < floor))
    if candidates.size == 0:
        return None
    nbr = _neighbours(tri)
    used = np.zeros(len(tri), dtype=bool)
    new_points: list[tuple[float, float]] = []
    fans: list[IntArray] = []
    for t in candidates[np.argsort(q[candidates], kind="stable")].tolist():
        best: tuple[float, float, float, list[int], list[int]] | None = None
        for tris, ring in _cavities(tri, nbr, t) + _chains(tri, nbr, t):
            if used[tris].any():
                continue
            # No angle below both the cavity's smallest and 30 degrees, so an input corner's
            # angle is only split where both halves stay above min(corner, 30). No slack: the
            # relaxation that follows takes the node to where its fan's worst is best, and
            # the smoother did not lift the angle back (a 56-degree wedge kept 28.2 after a
            # 3-degree slack, 52-degree ones 29.4 after half a degree).
            old = tri[tris]
            least = min(float(np.radians(min_angle(p, old)).min()), _THIRTY)
            x, y, worst, _, smallest = _place(p, np.asarray(ring, dtype=np.int64))
            gains = worst > radius_ratio(p, old).min() * (1.0 + GAIN) and smallest >= least
            gains = gains and not _swapped_into_corner(p, tri, nbr, tris, (x, y), least)
            if gains and (best is None or worst > best[2]):
                best = (x, y, worst, tris, ring)
        if best is None:
            continue
        x, y, _, tris, ring = best
        used[tris] = True
        node = mesh.n_points + len(new_points)
        new_points.append((x, y))
        fans.append(
            np.array([[a, b, node] for a, b in zip(ring, ring[1:] + ring[:1], strict=True)])
        )
    if not fans:
        return None
    return Mesh(
        np.concatenate([p, np.asarray(new_points)]),
        np.concatenate([tri[~used], *fans]).astype(np.int64),
    )
