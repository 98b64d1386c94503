"""Boundary slides: a node inside an input segment moves along it, nothing else does."""

from __future__ import annotations

import numpy as np

from engine import Mesh
from engine.quality import min_angle
from engine.slide import slide_round


def _fan() -> Mesh:
    """A square's bottom side split by a node at x = 0.1 (the square's corners and the top
    side's midpoint above): the node's triangles have angles far below 30 degrees."""
    pts = np.array([[0.0, 0], [0.1, 0], [1, 0], [1, 1], [0.5, 1], [0, 1]])
    tris = np.array([[0, 1, 5], [1, 4, 5], [1, 2, 4], [2, 3, 4]])
    return Mesh(pts, tris)


def test_a_node_inside_a_segment_slides_along_it_to_a_larger_smallest_angle() -> None:
    mesh = _fan()
    slid = slide_round(mesh)
    assert slid is not None
    moved = np.flatnonzero(np.any(slid.points != mesh.points, axis=1)).tolist()
    assert moved == [1]
    assert slid.points[1, 1] == 0.0  # still on the side
    assert 0.0 < slid.points[1, 0] < 1.0
    before = min_angle(mesh.points, mesh.triangles).min()
    assert min_angle(slid.points, slid.triangles).min() > before + 5.0


def test_input_vertices_and_held_sides_stay() -> None:
    mesh = _fan()
    top = (0.5, 1.0)  # the top side's node, an input vertex here
    assert slide_round(mesh, fixed_points={(0.1, 0.0), top}) is None
    assert slide_round(mesh, fixed_points={top}, held=[(0.0, 0.0, 0.1, 0.0)]) is None
    assert slide_round(mesh, fixed_points={top}) is not None
