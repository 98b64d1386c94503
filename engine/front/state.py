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

    pts: FloatArray  #: (n, 3) points and the size field there, the first ``st[NP]`` used
    tris: IntArray  #: (m, 3) triangles, the first ``st[NT]`` used
    slots: IntArray  #: (s, N_COLS) slot table (see constants)
    st: IntArray  #: (N_STATE,) scalar state (see constants)
    size: float  #: the field's size away from features (tells fine fronts apart)


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
