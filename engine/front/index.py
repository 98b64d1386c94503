"""Spatial index of front edges: insertion, rebuilding and the one walk over a box."""

from __future__ import annotations

import numba as nb

from .constants import ALIVE, NE, NEXT, NS, QUERY, VER, VERT
from .state import Front, Index


@nb.njit(cache=True, inline="always")
def cells(ix: Index, x0: float, y0: float, x1: float, y1: float) -> tuple[int, int, int, int]:
    """Grid cell index ranges (i0, i1, j0, j1), clamped to the grid, covering a box."""
    i0 = min(max(int((x0 - ix.x0) / ix.cell), 0), ix.nx - 1)
    i1 = min(max(int((x1 - ix.x0) / ix.cell), 0), ix.nx - 1)
    j0 = min(max(int((y0 - ix.y0) / ix.cell), 0), ix.ny - 1)
    j1 = min(max(int((y1 - ix.y0) / ix.cell), 0), ix.ny - 1)
    return i0, i1, j0, j1


@nb.njit(cache=True)
def insert(fr: Front, ix: Index, s: int) -> bool:
    """Index the edge of slot ``s`` at its current version; False when out of room."""
    slots, pts, st = fr.slots, fr.pts, fr.st
    a, b = slots[s, VERT], slots[slots[s, NEXT], VERT]
    x0, x1 = min(pts[a, 0], pts[b, 0]), max(pts[a, 0], pts[b, 0])
    y0, y1 = min(pts[a, 1], pts[b, 1]), max(pts[a, 1], pts[b, 1])
    i0, i1, j0, j1 = cells(ix, x0, y0, x1, y1)
    need = (i1 - i0 + 1) * (j1 - j0 + 1)
    if st[NE] + need > ix.ent.shape[0]:
        return False
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            c = j * ix.nx + i
            e = st[NE]
            ix.ent[e, 0] = s
            ix.ent[e, 1] = slots[s, VER]
            ix.ent[e, 2] = ix.head[c]
            ix.head[c] = e
            st[NE] += 1
    return True


@nb.njit(cache=True)
def rebuild(fr: Front, ix: Index) -> bool:
    """Drop dead entries: index the live slots afresh."""
    ix.head[:] = -1
    fr.st[NE] = 0
    for s in range(fr.st[NS]):  # noqa: SIM110 (numba compiles no all() over a generator)
        if fr.slots[s, ALIVE] == 1 and not insert(fr, ix, s):
            return False
    return True


@nb.njit(cache=True)
def gather(fr: Front, ix: Index, x0: float, y0: float, x1: float, y1: float) -> int:
    """Write the live slots whose edges may meet the box to ``ix.hits``, each once; returns
    how many.

    Cells are visited row by row and each cell's entries newest first; callers that keep the
    first of equal candidates depend on this order.
    """
    slots, stamp, ent, head, hits = fr.slots, fr.stamp, ix.ent, ix.head, ix.hits
    i0, i1, j0, j1 = cells(ix, x0, y0, x1, y1)
    fr.st[QUERY] += 1
    q = fr.st[QUERY]
    n = 0
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            g = head[j * ix.nx + i]
            while g >= 0:
                f = ent[g, 0]
                live = slots[f, ALIVE] == 1 and slots[f, VER] == ent[g, 1]
                g = ent[g, 2]
                if live and stamp[f] != q:
                    stamp[f] = q
                    hits[n] = f
                    n += 1
    return n
