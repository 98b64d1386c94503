"""The front kernel's state, as named tuples of arrays that every kernel takes.

The arrays grow between kernel calls (see :mod:`engine.front.driver`); the tuples are rebuilt
around them, so a kernel never holds an array that the driver replaced.

The kernels of the index, the queue, the checks, the slot updates and the main loop are
compiled without numba's reference counting (``_nrt=False``; :data:`NO_REFCOUNT` lists them):
with it, every array taken out of a tuple was counted up and down with atomic instructions,
and those took half of the front's time (perf: ``NRT_incref`` / ``NRT_decref``). The arrays
belong to the driver for the whole run, so no count is needed. A kernel without counting
cannot allocate, so its scratch arrays are in the tuples too (``touched``, ``stack``,
``bounds``). Together: 250,000 -> 640,000 triangles per CPU-second on the uniform square,
with the same meshes.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal, NamedTuple, TypeVar, cast

import numba as nb
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_F = TypeVar("_F", bound=Callable[..., Any])
# numba's option has no type stub; passed through a dict for the type checker.
_UNCOUNTED: dict[str, Any] = {"cache": True, "_nrt": False}


def uncounted(inline: Literal["never", "always"] = "never") -> Callable[[_F], _F]:
    """``numba.njit(cache=True)`` without reference counting, for the kernels of
    :data:`NO_REFCOUNT` (see above)."""
    return cast(Callable[[_F], _F], nb.njit(inline=inline, **_UNCOUNTED))


#: The front's kernels compiled without reference counting, by module (see above).
NO_REFCOUNT: dict[str, tuple[str, ...]] = {
    "checks": ("wedge_ok", "front_clear", "candidates_near", "gap_ahead"),
    "index": (
        "cells",
        "_new_node",
        "_insert_fine",
        "insert",
        "rebuild",
        "stale",
        "_collect",
        "_gather_fine",
    ),
    "queue": ("push", "pop", "slot_angle", "slot_key", "rebuild"),
    "slots": ("new_slot", "kill", "remove_spike", "refresh", "apply"),
    "driver": ("_run", "_init"),
}


class Front(NamedTuple):
    """Points, triangles, the slot table and the scalar state."""

    pts: FloatArray  #: (n, 3) points and the size field there, the first ``st[NP]`` used
    tris: IntArray  #: (m, 3) triangles, the first ``st[NT]`` used
    slots: IntArray  #: (s, N_COLS) slot table (see constants)
    st: IntArray  #: (N_STATE,) scalar state (see constants)
    size: float  #: the field's size away from features (tells fine fronts apart)
    touched: IntArray  #: scratch (8,): the slots one triangle's update touched


class Heap(NamedTuple):
    """Binary heap of slots waiting to advance (``st[NH]`` entries used; see queue)."""

    key: FloatArray  #: (k,) keys
    ref: IntArray  #: (k, 2) entries: slot and its version when pushed


class Index(NamedTuple):
    """Spatial index of front edges: a uniform grid of cells of the interior size, and in
    each cell a loose quadtree for the edges much shorter than a cell.

    An edge whose bounding box is wider than ``fine`` is listed in every cell its box
    meets; a shorter one in one tree node, the smallest that holds its centre and is at
    least as wide as the edge (see :mod:`engine.front.index`). Deletion is lazy: an entry
    is live while its slot is alive at the version it was inserted with.
    """

    head: IntArray  #: (nx * ny, 2) each cell's first entry and tree root (-1: none)
    ent: IntArray  #: (e, 3) entries: slot, slot version, next entry of the cell or node
    node: IntArray  #: (m, 5) tree nodes: four children, first entry (-1: none)
    fine: float  #: edges no wider than this go to the trees (0: the grid alone)
    x0: float  #: lower-left corner of the grid
    y0: float
    cell: float  #: cell side
    nx: int  #: cells along x
    ny: int  #: cells along y
    hits: IntArray  #: scratch: the slots a query found (one per slot at most)
    cand: IntArray  #: scratch: candidate apex slots
    stack: IntArray  #: scratch: tree nodes a query has still to visit
    bounds: FloatArray  #: scratch: their corners and sides (x, y, side)
