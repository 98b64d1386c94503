"""Independent sets of nodes: greedy colouring of the mesh's node adjacency.

Two nodes are adjacent when they share a triangle. Nodes of one colour share no triangle, so
they can move at the same time without seeing each other. Colouring greedily in a priority
order puts the most urgent nodes into the first sets.

>>> import numpy as np
>>> from engine.star import build_stars
>>> tri = np.array([[0, 1, 2], [0, 2, 3]])
>>> s = build_stars(tri, 4)
>>> independent_sets(np.array([0, 1, 2, 3]), s.ptr, s.opp_a, s.opp_b)
[array([0]), array([1, 3]), array([2])]
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["greedy_colour", "independent_sets"]

IntArray = NDArray[np.int64]


@numba.njit(cache=True)
def greedy_colour(order: IntArray, ptr: IntArray, opp_a: IntArray, opp_b: IntArray) -> IntArray:
    """Colour of each node of ``order``: the smallest not taken by an earlier-coloured neighbour.

    Nodes not in ``order`` are ignored (they constrain nothing).
    """
    n = len(ptr) - 1
    colour = np.full(n, -1, dtype=np.int64)
    widest = 0
    for i in range(n):
        widest = max(widest, ptr[i + 1] - ptr[i])
    taken = np.full(2 * widest + 2, -1, dtype=np.int64)
    out = np.empty(len(order), dtype=np.int64)
    for i in range(len(order)):
        node = order[i]
        for j in range(ptr[node], ptr[node + 1]):
            for v in (opp_a[j], opp_b[j]):
                if colour[v] >= 0:
                    taken[colour[v]] = i
        c = 0
        while taken[c] == i:
            c += 1
        colour[node] = c
        out[i] = c
    return out


def independent_sets(
    order: IntArray, ptr: IntArray, opp_a: IntArray, opp_b: IntArray
) -> list[IntArray]:
    """``order`` split into independent sets, first colour first, each set in ``order``'s order."""
    if len(order) == 0:
        return []
    colours = greedy_colour(np.ascontiguousarray(order, dtype=np.int64), ptr, opp_a, opp_b)
    by_colour = np.argsort(colours, kind="stable")
    bounds = np.flatnonzero(np.diff(colours[by_colour])) + 1
    return [order[idx] for idx in np.split(by_colour, bounds)]
