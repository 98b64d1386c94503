"""Narrow-gap search: the boundary each sample point faces across the region, on a box tree.

A boundary sample ``p`` (on segment ``own``, inward normal ``n_p``) faces segment ``g`` when the
nearest point ``q`` of ``g`` lies within the sample's reach, ahead of ``p`` (within 60 degrees
of ``n_p``) and ``p`` lies ahead of ``g`` likewise; segments adjacent to ``own`` are left to the
corner features. The search walks a median-split box tree over the segments (the cone tree's
build, :func:`engine.conetree.build_boxes`), so a sample costs the few segments within its
reach, not a query into a geometry library and numpy temporaries per candidate pair.
"""

from __future__ import annotations

from typing import NamedTuple

import numba as nb
import numpy as np
from numpy.typing import NDArray

from .boundary import Region
from .conetree import ConeTree, build_boxes, cone_min, slots_meeting

__all__ = ["GapSearch", "gap_search", "gap_widths", "ring_segments"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Cosine of the widest angle between a boundary point's inward normal and the direction to the
#: boundary it faces for the two to count as a gap (60 degrees: sharper corners count as gaps).
FACING_COS = 0.5
_STACK = 128


class GapSearch(NamedTuple):
    """Boundary segments, a box tree over them and the field that bounds each sample's reach."""

    a: FloatArray  #: (s, 2) segment starts
    b: FloatArray  #: (s, 2) segment ends
    normal: FloatArray  #: (s, 2) unit normals into the region
    prev: IntArray  #: (s,) previous segment of the same ring
    nxt: IntArray  #: (s,) next segment of the same ring
    order: IntArray  #: (s,) segment of each tree slot
    box: FloatArray  #: (m, 4) node boxes x0, y0, x1, y1
    child: IntArray  #: (m, 2) children of each node, -1 for a leaf
    span: IntArray  #: (m, 2) range of tree slots of each node
    reach: ConeTree  #: a sample looks ``reach(p) / factor`` far at most
    factor: float  #: size a gap asks for, as a fraction of its width


def ring_segments(region: Region) -> tuple[FloatArray, FloatArray, IntArray, IntArray]:
    """Segment starts and ends of every ring, and the previous / next segment of each."""
    starts, prev, nxt = [], [], []
    offset = 0
    for ring in region.rings:
        n = len(ring)
        starts.append(ring)
        idx = np.arange(n)
        prev.append(offset + (idx - 1) % n)
        nxt.append(offset + (idx + 1) % n)
        offset += n
    a = np.concatenate(starts)
    b = np.concatenate([np.roll(r, -1, axis=0) for r in region.rings])
    return a, b, np.concatenate(prev), np.concatenate(nxt)


def gap_search(region: Region, reach: ConeTree, factor: float) -> GapSearch:
    """The search over ``region``'s segments; samples look ``reach(p) / factor`` far."""
    a, b, prev, nxt = ring_segments(region)
    a, b = np.ascontiguousarray(a, np.float64), np.ascontiguousarray(b, np.float64)
    seg = b - a
    length = np.hypot(seg[:, 0], seg[:, 1])
    normal = np.stack([-seg[:, 1], seg[:, 0]], axis=1) / np.maximum(length, 1e-300)[:, None]
    order, box, child, span = build_boxes(a, b)
    return GapSearch(a, b, normal, prev, nxt, order, box, child, span, reach, factor)


@nb.njit(cache=True)
def _facing(
    g: GapSearch, own: int, px: float, py: float, reach: float, stack: IntArray, slots: IntArray
) -> float:  # pragma: no cover - compiled
    """Smallest ``factor * distance`` from ``p`` to a segment it faces within ``reach``."""
    best = np.inf
    npx, npy = g.normal[own, 0], g.normal[own, 1]
    query = (px - reach, py - reach, px + reach, py + reach)
    for i in range(slots_meeting(g.box, g.child, g.span, query, stack, slots)):
        s = g.order[slots[i]]
        if s == own or s == g.prev[own] or s == g.nxt[own]:
            continue  # adjacent segments meet at a corner: the corner feature covers that wedge
        sax, say = g.a[s, 0], g.a[s, 1]
        ddx, ddy = g.b[s, 0] - sax, g.b[s, 1] - say
        t = ((px - sax) * ddx + (py - say) * ddy) / max(ddx * ddx + ddy * ddy, 1e-300)
        t = min(max(t, 0.0), 1.0)
        vx, vy = sax + t * ddx - px, say + t * ddy - py
        dist = np.hypot(vx, vy)
        if dist > reach or dist <= 0.0:
            continue
        ln = max(np.hypot(ddx, ddy), 1e-300)
        nqx, nqy = -ddy / ln, ddx / ln
        ahead = vx * npx + vy * npy > FACING_COS * dist
        if ahead and -vx * nqx + -vy * nqy > FACING_COS * dist:
            best = min(best, g.factor * dist)
    return best


@nb.njit(cache=True, nogil=True)
def gap_widths(g: GapSearch, seg: IntArray, t: FloatArray) -> FloatArray:  # pragma: no cover
    """Size each point ``a[seg] + t (b[seg] - a[seg])`` asks for because it faces another part of
    the boundary within its reach (infinity where it faces none)."""
    out = np.empty(seg.shape[0])
    stack = np.empty(_STACK, dtype=np.int64)
    slots = np.empty(g.order.shape[0], dtype=np.int64)
    for i in range(seg.shape[0]):
        s = seg[i]
        px = g.a[s, 0] + t[i] * (g.b[s, 0] - g.a[s, 0])
        py = g.a[s, 1] + t[i] * (g.b[s, 1] - g.a[s, 1])
        out[i] = _facing(g, s, px, py, cone_min(g.reach, px, py)[0] / g.factor, stack, slots)
    return out
