"""Front updates: a triangle on a slot's edge rewires the loops of slots around it."""

from __future__ import annotations

from . import index, queue
from .constants import ALIVE, CURVED, FAIL, LAYER, LIVE, NEXT, NS, NT, PREV, STAMP, VER, VERT
from .state import Front, Heap, Index, uncounted


@uncounted()
def new_slot(fr: Front, vert: int) -> int:
    """A fresh live slot at vertex ``vert`` (its links are the caller's to set)."""
    slots, st = fr.slots, fr.st
    s = st[NS]
    st[NS] += 1
    slots[s, VERT] = vert
    slots[s, VER] = 0
    slots[s, FAIL] = 0
    slots[s, ALIVE] = 1
    slots[s, STAMP] = 0  # grown rows are not zeroed; queries count from 1
    st[LIVE] += 1
    return s


@uncounted()
def kill(fr: Front, s: int) -> None:
    """Take slot ``s`` off the front (its index and heap entries die with its liveness)."""
    fr.slots[s, ALIVE] = 0
    fr.st[LIVE] -= 1


@uncounted()
def remove_spike(fr: Front, x: int) -> int:
    """Drop a spike ``p -> x -> p`` at slot ``x``; returns a surviving neighbour, -1 when the
    loop vanished, -2 when there is no spike at ``x``."""
    slots = fr.slots
    p1, p2 = slots[x, PREV], slots[x, NEXT]
    if slots[p1, VERT] != slots[p2, VERT]:
        return -2
    if p1 == p2:  # a loop of two slots: both go
        kill(fr, x)
        kill(fr, p1)
        return -1
    n2 = slots[p2, NEXT]
    slots[p1, NEXT] = n2
    slots[n2, PREV] = p1
    kill(fr, x)
    kill(fr, p2)
    return p1


@uncounted()
def refresh(fr: Front, ix: Index, hp: Heap, s: int) -> bool:
    """Re-index a slot whose edge or angle changed: new version, index entry and heap entry."""
    slots = fr.slots
    if slots[s, ALIVE] != 1:
        return True
    slots[s, VER] += 1
    slots[s, FAIL] = 0
    if not index.insert(fr, ix, s):
        return False
    return queue.push(fr, hp, queue.slot_key(fr, s), s, slots[s, VER])


@uncounted()
def apply(fr: Front, ix: Index, hp: Heap, e: int, k: int, w: int) -> bool:
    """Add triangle (u, v, w) on the edge of slot ``e``; ``k`` is w's slot (-1 for a new point).

    Returns False when the index or the heap ran out of room mid-update.
    """
    slots, st, tris = fr.slots, fr.st, fr.tris
    t = slots[e, NEXT]
    u, v = slots[e, VERT], slots[t, VERT]
    n = st[NT]
    tris[n, 0], tris[n, 1], tris[n, 2] = u, v, w
    st[NT] += 1
    layer = slots[e, LAYER] + 1
    curved = slots[e, CURVED]
    touched = fr.touched
    nt = 0
    if k < 0:
        q = new_slot(fr, w)
        slots[q, LAYER] = layer
        slots[q, CURVED] = curved
        slots[e, LAYER] = layer
        slots[e, NEXT] = q
        slots[q, PREV] = e
        slots[q, NEXT] = t
        slots[t, PREV] = q
        touched[0], touched[1], touched[2] = e, q, t
        nt = 3
    else:
        pk = slots[k, PREV]
        k2 = new_slot(fr, w)
        slots[k2, LAYER] = layer
        slots[k2, CURVED] = curved
        slots[e, LAYER] = layer
        slots[e, NEXT] = k
        slots[k, PREV] = e
        slots[k2, PREV] = pk
        slots[pk, NEXT] = k2
        slots[k2, NEXT] = t
        slots[t, PREV] = k2
        touched[0], touched[1], touched[2], touched[3] = e, k, k2, t
        nt = 4
    # Cancel spikes (u -> w -> u and the like) left by closing against adjacent edges.
    changed = True
    while changed:
        changed = False
        for i in range(nt):
            x = touched[i]
            if slots[x, ALIVE] != 1:
                continue
            r = remove_spike(fr, x)
            if r != -2:
                changed = True
                if r >= 0 and nt < 8:
                    touched[nt] = r
                    nt += 1
    # A slot's angle depends on its previous, own and next vertex: exactly the touched slots
    # changed one of those (a spike's surviving neighbour changed its next vertex).
    for i in range(nt):  # noqa: SIM110 (numba compiles no all() over a generator)
        if not refresh(fr, ix, hp, touched[i]):
            return False
    return True
