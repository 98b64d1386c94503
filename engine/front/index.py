"""Spatial index of front edges: insertion, rebuilding and the one query (a box).

A uniform grid with cells of the interior size answers a query in a few cells where the
size is near uniform. Where the local size falls orders of magnitude below it (a slit, a
refined leading edge), thousands of short edges would share a cell and every query there
would scan them all (with the dead entries lazy deletion leaves); edges narrower than
``FINE_EDGE`` cells go instead to a loose quadtree rooted at their cell, in the node of their
own scale, and a query visits only the nodes near its box. Where no edge is that short the
trees stay empty and the grid answers alone, in the same order as before the trees existed.
"""

from __future__ import annotations

import numba as nb

from .constants import ALIVE, KEPT, NE, NEXT, NN, NS, QUERY, STAMP, VER, VERT
from .state import Front, Index, IntArray, uncounted

#: Edges whose bounding box is at most this fraction of a cell wide go to the trees.
FINE_EDGE = 0.25
#: Deepest tree level (node side cell / 2**MAX_DEPTH); narrower edges share that level.
MAX_DEPTH = 40
#: A node's entries reach at most LOOSE times its side outside it: half the side (an entry's
#: centre lies in its node and it is at most the side wide), plus slack for rounding.
LOOSE = 0.75
#: The index is rebuilt once it holds STALE times the entries it had after its last rebuild,
#: plus an eighth of the slots ever made (a rebuild reads them all) and STALE_MIN: deletion is
#: lazy, and where the front is fine (many edges a cell) the dead entries it leaves would make
#: the queries there slower and slower.
STALE = 2
STALE_MIN = 4096
#: Columns of ``Index.head``: the cell's list of entries, the cell's tree root.
LIST, TREE = 0, 1
#: Columns of ``Index.node``: four children (x then y halves), then the node's first entry.
HEAD = 4


@uncounted(inline="always")
def cells(ix: Index, x0: float, y0: float, x1: float, y1: float) -> tuple[int, int, int, int]:
    """Grid cell index ranges (i0, i1, j0, j1), clamped to the grid, covering a box."""
    i0 = min(max(int((x0 - ix.x0) / ix.cell), 0), ix.nx - 1)
    i1 = min(max(int((x1 - ix.x0) / ix.cell), 0), ix.nx - 1)
    j0 = min(max(int((y0 - ix.y0) / ix.cell), 0), ix.ny - 1)
    j1 = min(max(int((y1 - ix.y0) / ix.cell), 0), ix.ny - 1)
    return i0, i1, j0, j1


@uncounted()
def _new_node(fr: Front, ix: Index) -> int:
    n = fr.st[NN]
    fr.st[NN] += 1
    ix.node[n, :] = -1
    return n


@uncounted()
def _insert_fine(fr: Front, ix: Index, s: int, x0: float, y0: float, x1: float, y1: float) -> bool:
    """List slot ``s``'s edge (box x0..x1, y0..y1) in the tree of the cell of its centre, in
    the smallest node that holds the centre and is at least as wide as the box."""
    st, ent, node = fr.st, ix.ent, ix.node
    if st[NE] + 1 > ent.shape[0] or st[NN] + MAX_DEPTH + 1 > node.shape[0]:
        return False
    width = max(x1 - x0, y1 - y0)
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    i, _, j, _ = cells(ix, cx, cy, cx, cy)
    c = j * ix.nx + i
    n = ix.head[c, TREE]
    if n < 0:
        n = _new_node(fr, ix)
        ix.head[c, TREE] = n
    bx, by, side = ix.x0 + i * ix.cell, ix.y0 + j * ix.cell, ix.cell
    depth = 0
    while depth < MAX_DEPTH and width <= 0.5 * side:
        side *= 0.5
        qx = 1 if cx >= bx + side else 0
        qy = 1 if cy >= by + side else 0
        bx += qx * side
        by += qy * side
        child = node[n, 2 * qy + qx]
        if child < 0:
            child = _new_node(fr, ix)
            node[n, 2 * qy + qx] = child
        n = child
        depth += 1
    e = st[NE]
    ent[e, 0] = s
    ent[e, 1] = fr.slots[s, VER]
    ent[e, 2] = node[n, HEAD]
    node[n, HEAD] = e
    st[NE] += 1
    return True


@uncounted()
def insert(fr: Front, ix: Index, s: int) -> bool:
    """Index the edge of slot ``s`` at its current version; False when out of room."""
    slots, pts, st = fr.slots, fr.pts, fr.st
    a, b = slots[s, VERT], slots[slots[s, NEXT], VERT]
    x0, x1 = min(pts[a, 0], pts[b, 0]), max(pts[a, 0], pts[b, 0])
    y0, y1 = min(pts[a, 1], pts[b, 1]), max(pts[a, 1], pts[b, 1])
    if max(x1 - x0, y1 - y0) <= ix.fine:
        return _insert_fine(fr, ix, s, x0, y0, x1, y1)
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
            ix.ent[e, 2] = ix.head[c, LIST]
            ix.head[c, LIST] = e
            st[NE] += 1
    return True


@uncounted()
def rebuild(fr: Front, ix: Index) -> bool:
    """Drop dead entries and empty nodes: index the live slots afresh."""
    ix.head[:] = -1
    fr.st[NE] = 0
    fr.st[NN] = 0
    for s in range(fr.st[NS]):
        if fr.slots[s, ALIVE] == 1 and not insert(fr, ix, s):
            return False
    fr.st[KEPT] = fr.st[NE]
    return True


@uncounted(inline="always")
def stale(fr: Front) -> bool:
    """Whether dead entries are due to be dropped (see :data:`STALE`)."""
    st = fr.st
    return st[NE] > STALE * st[KEPT] + st[NS] // 8 + STALE_MIN


@uncounted(inline="always")
def _collect(slots: IntArray, ent: IntArray, hits: IntArray, g: int, q: int, n: int) -> int:
    """Append to ``hits[n:]`` the live slots of the list of entries from ``g`` not yet found
    by query ``q`` (stamping them); returns the new count."""
    while g >= 0:
        f = ent[g, 0]
        live = slots[f, ALIVE] == 1 and slots[f, VER] == ent[g, 1]
        g = ent[g, 2]
        if live and slots[f, STAMP] != q:
            slots[f, STAMP] = q
            hits[n] = f
            n += 1
    return n


# Counted: tests call it from Python; inlined, it takes its caller's options.
@nb.njit(cache=True, inline="always")
def gather(fr: Front, ix: Index, x0: float, y0: float, x1: float, y1: float) -> int:
    """Write the live slots whose edges may meet the box to ``ix.hits``, each once; returns
    how many.

    Cells are visited row by row and each cell's entries newest first, then the trees (cells
    row by row, nodes depth first); callers that keep the first of equal candidates depend
    on this order.
    """
    slots, ent, head, hits = fr.slots, ix.ent, ix.head, ix.hits
    i0, i1, j0, j1 = cells(ix, x0, y0, x1, y1)
    fr.st[QUERY] += 1
    q = fr.st[QUERY]
    n = 0
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            n = _collect(slots, ent, hits, head[j * ix.nx + i, LIST], q, n)
    if fr.st[NN] > 0:  # some edges are in trees
        n = _gather_fine(fr, ix, x0, y0, x1, y1, n)
    return n


@uncounted()
def _gather_fine(fr: Front, ix: Index, x0: float, y0: float, x1: float, y1: float, n: int) -> int:
    """Append to ``ix.hits[n:]`` the live slots of the trees whose nodes may reach the box."""
    slots, ent, node, hits = fr.slots, ix.ent, ix.node, ix.hits
    q = fr.st[QUERY]
    # Depth first: at most three siblings wait per level.
    stack, bounds = ix.stack, ix.bounds
    # Entries sit in nodes at most ``fine`` wide, so they reach at most LOOSE of that outside
    # their cell.
    pad = LOOSE * ix.fine
    i0, i1, j0, j1 = cells(ix, x0 - pad, y0 - pad, x1 + pad, y1 + pad)
    for j in range(j0, j1 + 1):
        for i in range(i0, i1 + 1):
            r = ix.head[j * ix.nx + i, TREE]
            if r < 0:
                continue
            stack[0] = r
            bounds[0, 0], bounds[0, 1], bounds[0, 2] = (
                ix.x0 + i * ix.cell,
                ix.y0 + j * ix.cell,
                ix.cell,
            )
            top = 1
            while top > 0:
                top -= 1
                m = stack[top]
                bx, by, side = bounds[top, 0], bounds[top, 1], bounds[top, 2]
                reach = LOOSE * side
                if (
                    bx - reach > x1
                    or bx + side + reach < x0
                    or by - reach > y1
                    or by + side + reach < y0
                ):
                    continue
                n = _collect(slots, ent, hits, node[m, HEAD], q, n)
                half = 0.5 * side
                for k in range(4):
                    if node[m, k] >= 0:
                        stack[top] = node[m, k]
                        bounds[top, 0] = bx + (k % 2) * half
                        bounds[top, 1] = by + (k // 2) * half
                        bounds[top, 2] = half
                        top += 1
    return n
