"""validate_mesh refuses meshes whose triangles overlap, and keeps pieces that abut or touch."""

from __future__ import annotations

import numpy as np
import pytest

from engine.errors import InvalidMesh
from engine.mesh import validate_mesh


def _grid(n: int, x0: float = 0.0, y0: float = 0.0, side: float = 1.0):  # type: ignore[no-untyped-def]
    x, y = np.meshgrid(np.linspace(x0, x0 + side, n), np.linspace(y0, y0 + side, n))
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    b, c = a + 1, a + n
    d = c + 1
    return np.c_[x.ravel(), y.ravel()], np.r_[np.c_[a, b, d], np.c_[a, d, c]]


def _two(first, second):  # type: ignore[no-untyped-def]
    (p, t), (q, u) = first, second
    return np.r_[p, q], np.r_[t, u + len(p)]


GRID = _grid(20)

OVERLAPPING = {
    # One more triangle over the grid's lower right half: all its edges are boundary edges,
    # and no interior node folds (the check before this one saw nothing).
    "a triangle laid over the grid": (GRID[0], np.r_[GRID[1], [[0, 19, 399]]]),
    "a piece inside another": _two(GRID, _grid(3, 0.4, 0.4, 0.1)),
    "a shifted copy": _two(GRID, _grid(20, 0.5, 0.5)),
    "a copy on top": _two(GRID, GRID),
}

FINE = {
    "abutting, nodes matching": _two(GRID, _grid(20, 1.0, 0.0)),
    "abutting, nodes not matching": _two(GRID, _grid(13, 1.0, 0.0)),
    "touching at a corner": _two(GRID, _grid(5, 1.0, 1.0)),
    "apart": _two(GRID, _grid(5, 3.0, 3.0)),
}


@pytest.mark.parametrize("case", sorted(OVERLAPPING))
def test_overlapping_triangles_are_refused(case: str) -> None:
    points, triangles = OVERLAPPING[case]
    with pytest.raises(InvalidMesh, match=r"overlap|lies over another"):
        validate_mesh(points, triangles)


@pytest.mark.parametrize("case", sorted(FINE))
def test_pieces_that_abut_touch_or_lie_apart_are_valid(case: str) -> None:
    points, triangles = FINE[case]
    assert validate_mesh(points, triangles).n_triangles == len(triangles)
