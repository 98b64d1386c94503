"""The order in which slots advance: a binary heap of (key, slot, version), lazily invalidated."""

from __future__ import annotations

import math

from .constants import (
    ALIVE,
    FAIL,
    FINE,
    FINE_LEAD,
    LAYER,
    MAX_TRIES,
    NEXT,
    NH,
    NS,
    PREV,
    SIZE,
    T_CLOSE,
    T_FLAT,
    TWO_PI,
    VER,
    VERT,
)  # fmt: skip
from .geometry import ccw
from .state import Front, Heap, uncounted


@uncounted()
def push(fr: Front, hp: Heap, key: float, s: int, ver: int) -> bool:
    """Queue slot ``s`` at version ``ver``; False when the heap is full."""
    hkey, href, st = hp.key, hp.ref, fr.st
    n = st[NH]
    if n >= hkey.shape[0]:
        return False
    hkey[n] = key
    href[n, 0] = s
    href[n, 1] = ver
    while n > 0:
        parent = (n - 1) >> 1
        if hkey[parent] <= hkey[n]:
            break
        hkey[parent], hkey[n] = hkey[n], hkey[parent]
        t0, t1 = href[parent, 0], href[parent, 1]
        href[parent, 0], href[parent, 1] = href[n, 0], href[n, 1]
        href[n, 0], href[n, 1] = t0, t1
        n = parent
    st[NH] += 1
    return True


@uncounted()
def pop(fr: Front, hp: Heap) -> tuple[float, int, int]:
    """The smallest (key, slot, version); the heap must not be empty."""
    hkey, href, st = hp.key, hp.ref, fr.st
    key, s, ver = hkey[0], href[0, 0], href[0, 1]
    st[NH] -= 1
    n = st[NH]
    hkey[0] = hkey[n]
    href[0, 0], href[0, 1] = href[n, 0], href[n, 1]
    i = 0
    while True:
        left = 2 * i + 1
        if left >= n:
            break
        m = left
        if left + 1 < n and hkey[left + 1] < hkey[left]:
            m = left + 1
        if hkey[i] <= hkey[m]:
            break
        hkey[i], hkey[m] = hkey[m], hkey[i]
        t0, t1 = href[i, 0], href[i, 1]
        href[i, 0], href[i, 1] = href[m, 0], href[m, 1]
        href[m, 0], href[m, 1] = t0, t1
        i = m
    return key, s, ver


@uncounted()
def slot_angle(fr: Front, s: int) -> float:
    """Interior angle of the front at slot ``s``'s vertex (2 pi for a spike)."""
    slots, pts = fr.slots, fr.pts
    b = slots[s, VERT]
    a = slots[slots[s, PREV], VERT]
    c = slots[slots[s, NEXT], VERT]
    ang = ccw(
        pts[c, 0] - pts[b, 0], pts[c, 1] - pts[b, 1], pts[a, 0] - pts[b, 0], pts[a, 1] - pts[b, 1]
    )
    return ang if ang > 0.0 else TWO_PI


@uncounted()
def slot_key(fr: Front, s: int) -> float:
    """Smallest angle first; slots flatter than ``T_FLAT`` tie, and ties go to the older front
    layer, then to the shorter edge (relative to the local size). Failed slots go last.

    A slot where the size field is below ``FINE`` times its size away from features, unless it
    is a corner to close, comes as if its angle were ``FINE_LEAD`` smaller: fronts that must
    grade up from a fine boundary (a small hole's, a refined leading edge's) then advance
    before coarse fronts reach them. Coarse rows advance by their own small angles row after
    row, while a hole's front is all reflex angles; left to the angle order it was reached
    after a layer or two, and a coarse row met its fine edges with boundary nodes a triangle
    short (two of 93 degrees: no node move mends that)."""
    slots, pts = fr.slots, fr.pts
    a, b = slots[s, VERT], slots[slots[s, NEXT], VERT]
    length = math.hypot(pts[b, 0] - pts[a, 0], pts[b, 1] - pts[a, 1]) / pts[a, SIZE]
    key = slot_angle(fr, s)
    if key >= T_FLAT:
        key = T_FLAT + 1e-3 * slots[s, LAYER]
    if key >= T_CLOSE and pts[a, SIZE] < FINE * fr.size:
        key -= FINE_LEAD
    return key + 1e-7 * min(length, 10.0) + 1e6 * slots[s, FAIL]


@uncounted()
def rebuild(fr: Front, hp: Heap) -> bool:
    """Queue every live slot that has tries left, dropping stale entries."""
    slots = fr.slots
    fr.st[NH] = 0
    for s in range(fr.st[NS]):
        waiting = slots[s, ALIVE] == 1 and slots[s, FAIL] < MAX_TRIES
        if waiting and not push(fr, hp, slot_key(fr, s), s, slots[s, VER]):
            return False
    return True
