"""The front kernel's state, as named tuples of arrays that every kernel takes.

The arrays grow between kernel calls (see :mod:`engine.front.driver`); the tuples are rebuilt
around them, so a kernel never holds an array that the driver replaced.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


class Front(NamedTuple):
    """Points, triangles, the slot table and the scalar state."""

    pts: FloatArray  #: (n, 2) points, the first ``st[NP]`` used
    hv: FloatArray  #: (n,) size field at each point
    tris: IntArray  #: (m, 3) triangles, the first ``st[NT]`` used
    slots: IntArray  #: (s, N_COLS) slot table (see constants)
    st: IntArray  #: (N_STATE,) scalar state (see constants)
    stamp: IntArray  #: (s,) last query that visited each slot
    size: float  #: the field's size away from features (tells fine fronts apart)


class Heap(NamedTuple):
    """Binary heap of slots waiting to advance (``st[NH]`` entries used; see queue)."""

    key: FloatArray  #: (k,) keys
    ref: IntArray  #: (k, 2) entries: slot and its version when pushed


class Index(NamedTuple):
    """Spatial index of front edges: a uniform grid of cells holding linked lists of entries.

    Deletion is lazy: an entry is live while its slot is alive at the version it was
    inserted with.
    """

    head: IntArray  #: (nx * ny,) first entry of each cell, -1 when empty
    ent: IntArray  #: (e, 3) entries: slot, slot version, next entry of the cell
    x0: float  #: lower-left corner of the grid
    y0: float
    cell: float  #: cell side
    nx: int  #: cells along x
    ny: int  #: cells along y
    hits: IntArray  #: scratch: the slots a query found (one per slot at most)
    cand: IntArray  #: scratch: candidate apex slots
