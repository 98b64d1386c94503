"""A catalogue of small meshes and the round-trip helper every format test runs over them
(as meshio's ``write_read`` over its ``tests/helpers.py`` meshes)."""

from __future__ import annotations

from typing import Any

import numpy as np

import engine
from service.formats import ResultFormat, StoredResult

from ...engine.random_meshes import random_mesh


def document(mesh: engine.Mesh) -> dict[str, Any]:
    """A mesh document of ``mesh`` with its quality fields and node fitness."""
    snap = engine.assess_mesh(mesh)
    return {
        "points": mesh.points.tolist(),
        "triangles": mesh.triangles.tolist(),
        "point_data": {
            "fitness": snap.fitness.tolist(),
            "boundary": mesh.boundary_nodes.astype(int).tolist(),
        },
        "cell_data": {
            name: getattr(snap.quality, name).tolist()
            for name in ("quality", "radius_ratio", "min_angle", "max_angle")
        },
    }


def _catalogue() -> dict[str, dict[str, Any]]:
    equilateral = [[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]]
    square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    far = [[5e5 + x, 4e6 + y] for x, y in square]  # projected metres: digits a writer must keep
    return {
        "one triangle": document(engine.validate_mesh(equilateral, [[0, 1, 2]])),
        "square": document(engine.validate_mesh(square, [[0, 1, 2], [0, 2, 3]])),
        "far from the origin": document(engine.validate_mesh(far, [[0, 1, 3], [1, 2, 3]])),
        "random, holes": document(random_mesh(3)),
        "random, stretched": document(random_mesh(11, max_cells=5)),
    }


#: Named mesh documents every format is run over.
CATALOGUE = _catalogue()


def write_read(fmt: ResultFormat, doc: dict[str, Any]) -> dict[str, Any]:
    """``doc`` written in ``fmt`` and read back."""
    return fmt.read(fmt.render(StoredResult(doc=doc), {}))


def assert_same_mesh(back: dict[str, Any], doc: dict[str, Any]) -> None:
    """``back`` holds the mesh of ``doc``: same points (to the last digit), triangles and fields."""
    np.testing.assert_array_equal(np.asarray(back["points"]), np.asarray(doc["points"]))
    np.testing.assert_array_equal(np.asarray(back["triangles"]), np.asarray(doc["triangles"]))
    for group in ("cell_data", "point_data"):
        assert set(back[group]) == set(doc[group]), group
        for name, values in doc[group].items():
            np.testing.assert_array_equal(np.asarray(back[group][name]), np.asarray(values))
