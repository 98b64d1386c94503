"""Boundary slides: a boundary node inside an input segment moves along it.

The discretisation places a segment's nodes by the size field alone, and the side splits add
nodes where a triangle needed one; neither sees the triangles the front then builds. Where a
triangle keeps an angle below the bound the input sets (min(smallest boundary angle, 30)), a
node of it that lies inside an input segment, between two boundary neighbours on the same
straight line, may slide along that line between them: the region stays covered exactly and
every input vertex stays. So may the nodes of a triangle holding an input corner whole short
of the isosceles triangle at that corner (:func:`engine.sides.corner_figures`). The node goes
where its star's smallest angle (up to the bound) is largest and then its worst radius ratio,
and moves only when that beats where it is.

The side splits add nodes but never move one, so a node they placed for one cavity stays where
a later split made it a poor neighbour: a 39.8-degree spike kept a rung at 29.0 degrees beside a
split node close to the corner's own node; slid along its leg, 30.1.
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np
from numpy.typing import NDArray

from .mesh import Mesh
from .quality import min_angle
from .relax import node_stars
from .sides import Line, _corner_bound, _fan, _search_line, corner_figures

__all__ = ["SLIDE_ROUNDS", "slide_round"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Passes of :func:`slide_round` in the mesher (a node moved changes its neighbours' stars).
SLIDE_ROUNDS = 2
#: The node keeps at least this fraction of the span from either neighbour.
_MARGIN = 0.05
#: Where the node is tried: 33 evenly spaced places between those margins, then halving.
_ALONG = Line(_MARGIN, 1.0 - 2.0 * _MARGIN, 32, 0, 32)
#: Cross product (relative to the squared span) under which three nodes count as collinear.
_COLLINEAR = 1e-12


def _link(tri: IntArray, tri_of: IntArray, v: int) -> list[int] | None:
    """The neighbours of boundary node ``v`` in counter-clockwise order, from the boundary
    neighbour after ``v`` to the one before it; None when its star is not a fan."""
    after = {}
    for t in tri_of.tolist():
        a, b, c = (int(x) for x in tri[t])
        u, w = (b, c) if a == v else ((c, a) if b == v else (a, b))
        after[u] = w
    heads = set(after) - set(after.values())
    if len(heads) != 1:
        return None
    chain = [heads.pop()]
    while chain[-1] in after and len(chain) <= len(after):
        chain.append(after[chain[-1]])
    return chain if len(chain) == len(after) + 1 else None


def slide_round(
    mesh: Mesh,
    fixed_points: Collection[tuple[float, float]] = (),
    held: Collection[tuple[float, float, float, float]] = (),
) -> Mesh | None:
    """One pass of boundary slides (see the module's text) over the nodes of the triangles
    below the bound; None when no node moved. Nodes at ``fixed_points`` (the input vertices)
    never move, nor do the ends of boundary sides in ``held`` (by their ends' coordinates,
    either way)."""
    if mesh.n_triangles == 0:
        return None
    p, tri = mesh.points, mesh.triangles
    bound = _corner_bound(mesh)
    low = (min_angle(p, tri) < bound) | corner_figures(mesh)[2]
    if not low.any():
        return None
    boundary = mesh.boundary_nodes
    nodes = np.unique(tri[low])
    nodes = nodes[boundary[nodes]]
    if nodes.size == 0:
        return None
    fixed = set(fixed_points)
    for ax, ay, bx, by in held:
        fixed.update(((ax, ay), (bx, by)))
    start, tri_of = node_stars(tri, mesh.n_points)
    points = p.copy()
    cap = np.radians(bound)
    moved = False
    for v in nodes.tolist():
        if (float(p[v, 0]), float(p[v, 1])) in fixed:
            continue
        chain = _link(tri, tri_of[start[v] : start[v + 1]], v)
        if chain is None or not (boundary[chain[0]] and boundary[chain[-1]]):
            continue
        a, b = points[chain[0]], points[chain[-1]]
        span = b - a
        cross = (points[v, 0] - a[0]) * span[1] - (points[v, 1] - a[1]) * span[0]
        if abs(cross) > _COLLINEAR * float(span @ span):
            continue  # a corner of the boundary, not a node inside a straight segment
        arr = np.asarray(chain, dtype=np.int64)
        here = _fan_here(points, arr, points[v], cap)
        at, smallest, worst = _search_line(points, arr, chain[0], chain[-1], _ALONG, cap)
        if (smallest, worst) > here:
            points[v] = a + at * span
            moved = True
    return mesh.with_points(points) if moved else None


def _fan_here(p: FloatArray, chain: IntArray, xy: FloatArray, cap: float) -> tuple[float, float]:
    """The fan's smallest angle (up to ``cap``) and worst radius ratio with the node at ``xy``."""
    worst, _, smallest = _fan(p, chain, float(xy[0]), float(xy[1]), chain.shape[0] - 1)
    return min(smallest, cap), worst
