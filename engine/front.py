"""Advancing-front triangulation (placeholder: fills the boundary with the cavity filler)."""

from __future__ import annotations

import numpy as np

from .cavity import fill_cavities
from .discretize import Discretized
from .mesh import Mesh
from .result import StopFn
from .sizing import SizeField

__all__ = ["advance_front"]


def advance_front(
    boundary: Discretized, field: SizeField, should_stop: StopFn | None = None
) -> Mesh:
    """Triangulate the region bounded by ``boundary``."""
    del field, should_stop
    tris = fill_cavities(boundary.points, boundary.edges)
    return Mesh(np.ascontiguousarray(boundary.points), tris)
