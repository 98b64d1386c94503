"""Diagonal swapping (placeholder until the swapping stage lands: returns the mesh unchanged)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .mesh import Mesh

__all__ = ["swap_diagonals"]


def swap_diagonals(mesh: Mesh, fixed_edges: NDArray[np.int64] | None = None) -> Mesh:
    """Flip interior edges while the worse of the two triangles improves."""
    del fixed_edges
    return mesh
