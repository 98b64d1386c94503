"""The front's main loop (numba) and :func:`advance_front`, which sets up and grows its arrays."""

from __future__ import annotations

import math
from typing import Any, TypeVar, cast

import numpy as np

from ..cavity import fill_cavities
from ..discretize import Discretized
from ..errors import Cancelled, LimitExceeded, MeshingError
from ..mesh import Mesh
from ..result import StopFn
from ..sizing import SizeField, SizeTuple
from . import index, queue
from .constants import (
    ALIVE,
    BUDGET,
    CURVE_MAX,
    CURVE_MIN,
    CURVED,
    DONE,
    FAIL,
    GROW,
    LIVE,
    MADE,
    MAX_CANDIDATES,
    MAX_TRIES,
    N_COLS,
    N_STATE,
    NE,
    NEXT,
    NH,
    NN,
    NO_ROOM,
    NP,
    NS,
    NT,
    OPS,
    PREV,
    RELAX_LEFT,
    RELAXED,
    SIZE,
    STUCK,
    VER,
    VERT,
)  # fmt: skip
from .rules import process
from .state import FloatArray, Front, Heap, Index, IntArray, uncounted

__all__ = ["advance_front"]


@uncounted()
def _run(fr: Front, ix: Index, hp: Heap, sf: SizeTuple, budget: int) -> int:
    """Advance the front by up to ``budget`` triangles; returns a status code."""
    slots, st = fr.slots, fr.st
    done = 0
    while done < budget:
        if st[LIVE] == 0:
            return DONE
        if (
            st[NP] + 2 > fr.pts.shape[0]
            or st[NT] + 2 > fr.tris.shape[0]
            or st[NS] + 4 > slots.shape[0]
        ):
            return GROW
        if ix.hits.shape[0] < slots.shape[0]:
            return GROW
        if st[NH] + 64 > hp.key.shape[0] and (
            not queue.rebuild(fr, hp) or st[NH] + 64 > hp.key.shape[0]
        ):
            return GROW
        if st[NE] + 4096 > ix.ent.shape[0] or st[NN] + 4096 > ix.node.shape[0] or index.stale(fr):
            if not index.rebuild(fr, ix):
                return GROW
            if st[NE] + 4096 > ix.ent.shape[0] or st[NN] + 4096 > ix.node.shape[0]:
                return GROW
        if st[NH] == 0:
            if st[RELAXED] > 0:
                return STUCK
            # Nothing can advance under the normal rules: relax them for a while.
            st[RELAXED] = 1
            st[RELAX_LEFT] = st[LIVE] + 16
            for s in range(st[NS]):
                slots[s, FAIL] = 0
            queue.rebuild(fr, hp)
            continue
        _, s, ver = queue.pop(fr, hp)
        if slots[s, ALIVE] != 1 or slots[s, VER] != ver:
            continue
        r = process(fr, ix, hp, sf, s)
        if r == NO_ROOM:
            return -1
        if r == MADE:
            done += 1
            st[OPS] += 1
            if st[RELAXED] > 0:
                st[RELAX_LEFT] -= 1
                if st[RELAX_LEFT] <= 0:
                    st[RELAXED] = 0
        else:
            slots[s, FAIL] += 1
            if slots[s, FAIL] < MAX_TRIES:
                queue.push(fr, hp, queue.slot_key(fr, s), s, slots[s, VER])
    return BUDGET


@uncounted()
def _init(fr: Front, ix: Index, hp: Heap) -> bool:
    """Index and queue every slot; False when the index or the heap is too small."""
    return index.rebuild(fr, ix) and queue.rebuild(fr, hp)


_A = TypeVar("_A", bound=np.ndarray[Any, Any])


def _bigger(arr: _A, used: int, need: int) -> _A:
    if used + need <= len(arr):
        return arr
    new = np.empty((max(2 * len(arr), used + need), *arr.shape[1:]), dtype=arr.dtype)
    new[:used] = arr[:used]
    return cast(_A, new)


def _grown(fr: Front, ix: Index, hp: Heap, budget: int) -> tuple[Front, Index, Heap]:
    """The state with room for ``budget`` more triangles (doubling what is short)."""
    st = fr.st
    slots = _bigger(fr.slots, int(st[NS]), 2 * budget + 8)
    fr = fr._replace(
        pts=_bigger(fr.pts, int(st[NP]), budget + 8),
        tris=_bigger(fr.tris, int(st[NT]), budget + 8),
        slots=slots,
    )
    hits = ix.hits if len(ix.hits) >= len(slots) else np.empty(len(slots), dtype=np.int64)
    ix = ix._replace(
        ent=_bigger(ix.ent, int(st[NE]), 40 * budget + 8192),
        node=_bigger(ix.node, int(st[NN]), 4 * budget + 8192),
        hits=hits,
    )
    hp = Heap(
        key=_bigger(hp.key, int(st[NH]), 10 * budget + 1024),
        ref=_bigger(hp.ref, int(st[NH]), 10 * budget + 1024),
    )
    return fr, ix, hp


def _new_index(points: FloatArray, field: SizeField, n_edges: int, n_slots: int) -> Index:
    """A grid of cells of the field's size (at most 2048 along the longer side), with trees
    for edges narrower than ``index.FINE_EDGE`` cells."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-300))
    cell = max(field.size, span / 2048.0)
    pad = 0.5 * cell
    nx = math.ceil((hi[0] - lo[0] + 2 * pad) / cell) + 1
    ny = math.ceil((hi[1] - lo[1] + 2 * pad) / cell) + 1
    return Index(
        head=np.full((nx * ny, 2), -1, dtype=np.int64),
        ent=np.empty((16 * n_edges + 8192, 3), dtype=np.int64),
        x0=float(lo[0] - pad),
        y0=float(lo[1] - pad),
        cell=float(cell),
        nx=nx,
        ny=ny,
        node=np.empty((4 * n_edges + 8192, 5), dtype=np.int64),
        fine=index.FINE_EDGE * float(cell),
        hits=np.empty(n_slots, dtype=np.int64),
        cand=np.empty(MAX_CANDIDATES, dtype=np.int64),
        stack=np.empty(4 * index.MAX_DEPTH + 8, dtype=np.int64),
        bounds=np.empty((4 * index.MAX_DEPTH + 8, 3)),
    )


def _curved_edges(points: FloatArray, edges: IntArray) -> IntArray:
    """1 for boundary edges whose both ends turn by CURVE_MIN..CURVE_MAX degrees (a curve drawn
    as a polygon), 0 for straight stretches and corners."""
    n = len(points)
    nxt = np.full(n, -1, dtype=np.int64)
    nxt[edges[:, 0]] = edges[:, 1]
    prv = np.full(n, -1, dtype=np.int64)
    prv[edges[:, 1]] = edges[:, 0]
    d_in = points - points[prv]
    d_out = points[nxt] - points
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    turn = np.abs(np.degrees(np.arctan2(cross, (d_in * d_out).sum(axis=1))))
    smooth = (turn > CURVE_MIN) & (turn < CURVE_MAX)
    return (smooth[edges[:, 0]] & smooth[edges[:, 1]]).astype(np.int64)


def _region_area(points: FloatArray, edges: IntArray) -> float:
    a, b = points[edges[:, 0]], points[edges[:, 1]]
    return 0.5 * float(np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]))


def _new_front(boundary: Discretized, field: SizeField, est: int) -> Front:
    """The front of the boundary's loops, with room for about ``est`` triangles."""
    points, edges = boundary.points, boundary.edges
    n0 = len(points)
    pts = np.empty((est // 2 + n0 + 16, 3))
    pts[:n0, :2] = points
    pts[:n0, SIZE] = boundary.sizes
    slots = np.zeros((2 * len(pts), N_COLS), dtype=np.int64)
    start_of = np.full(n0, -1, dtype=np.int64)
    start_of[edges[:, 0]] = np.arange(len(edges))
    nxt = start_of[edges[:, 1]]
    slots[: len(edges), VERT] = edges[:, 0]
    slots[: len(edges), NEXT] = nxt
    slots[nxt, PREV] = np.arange(len(edges))
    slots[: len(edges), ALIVE] = 1
    slots[: len(edges), CURVED] = _curved_edges(points, edges)
    st = np.zeros(N_STATE, dtype=np.int64)
    st[NP], st[NS], st[LIVE] = n0, len(edges), len(edges)
    return Front(
        pts=pts,
        tris=np.empty((est, 3), dtype=np.int64),
        slots=slots,
        st=st,
        size=float(field.size),
        touched=np.empty(8, dtype=np.int64),
    )


def advance_front(
    boundary: Discretized,
    field: SizeField,
    should_stop: StopFn | None = None,
    budget: int = 50_000,
    max_triangles: int = 5_000_000,
) -> Mesh:
    """Triangulate the region bounded by ``boundary`` following ``field``.

    >>> from engine.boundary import make_region
    >>> from engine.discretize import discretize
    >>> from engine.params import SizingParams
    >>> from engine.sizing import build_size_field
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> field = build_size_field(square, SizingParams(size=0.2))
    >>> mesh = advance_front(discretize(square, field), field)
    >>> bool(abs(mesh.areas.sum() - 1.0) < 1e-12), bool(mesh.areas.min() > 0)
    (True, True)
    """
    points, edges = boundary.points, boundary.edges
    n0 = len(points)
    est = int(max(_region_area(points, edges), 0.0) / (0.433 * field.size**2) * 1.2) + 2 * n0 + 64
    est = min(est, 4 * budget + 2 * n0 + 64)
    fr = _new_front(boundary, field, est)
    ix = _new_index(points, field, len(edges), len(fr.slots))
    n_heap = 4 * len(edges) + 1024
    hp = Heap(key=np.empty(n_heap), ref=np.empty((n_heap, 2), dtype=np.int64))
    while not _init(fr, ix, hp):
        ix = ix._replace(
            ent=_bigger(ix.ent, len(ix.ent), len(ix.ent)),
            node=_bigger(ix.node, len(ix.node), len(ix.node)),
        )
    sf = field.as_tuple()
    st = fr.st
    # Chunks no larger than the mesh, so small jobs do not allocate for large ones.
    budget = max(min(budget, 2 * est), 256)
    while True:
        fr, ix, hp = _grown(fr, ix, hp, budget)
        status = _run(fr, ix, hp, sf, budget)
        if status in (DONE, STUCK):
            break
        if status < 0:
            raise MeshingError("the advancing front ran out of room mid-update")
        if should_stop is not None and should_stop():
            raise Cancelled("stopped while meshing")
        if st[NT] > max_triangles:
            raise LimitExceeded(
                f"meshing passed the limit of {max_triangles} triangles",
                limit=max_triangles,
                estimate=int(st[NT]),
            )
    pts_out = fr.pts[: int(st[NP]), :2].copy()
    tris_out = fr.tris[: int(st[NT])].copy()
    if status == STUCK:
        ns = int(st[NS])
        alive = np.flatnonzero(fr.slots[:ns, ALIVE] == 1)
        rest = np.stack([fr.slots[alive, VERT], fr.slots[fr.slots[alive, NEXT], VERT]], axis=1)
        tris_out = np.concatenate([tris_out, fill_cavities(pts_out, rest)])
    return Mesh(pts_out, tris_out)
