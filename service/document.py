"""The mesh document (DESIGN.md): the native JSON form of a result, and reading meshes back."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np
from numpy.typing import NDArray

from engine import METRICS, Mesh, Result, Snapshot, validate_mesh
from engine.errors import InvalidMesh

__all__ = ["cell_data", "mesh_from_document", "result_document"]


def cell_data(snap: Snapshot) -> dict[str, list[float]]:
    """The ``cell_data`` of a document: each metric of :data:`engine.METRICS` per triangle."""
    return {name: snap.quality[name].tolist() for name in METRICS}


def result_document(
    result: Result, to_lonlat: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None
) -> dict[str, Any]:
    """The mesh document of ``result``.

    ``points``/``triangles``/``point_data``/``cell_data`` describe the final mesh; ``initial``
    holds the mesh as first meshed (before swapping and smoothing) with its own cell data, so
    clients can compare; ``summary`` holds each stage's figures, parameters, timings and the
    smoothing history. With ``to_lonlat`` (a region given in wgs84) points are lon/lat and
    ``points_local`` keeps the metric coordinates the figures refer to.
    """
    final, first = result.smoothed, result.initial

    def pts(snap: Snapshot) -> list[list[float]]:
        xy = snap.mesh.points
        return (to_lonlat(xy) if to_lonlat is not None else xy).tolist()

    doc: dict[str, Any] = {
        "points": pts(final),
        "triangles": final.mesh.triangles.tolist(),
        "point_data": {
            "fitness": final.fitness.tolist(),
            "fitness_initial": first.fitness.tolist(),
            "boundary": final.mesh.boundary_nodes.astype(int).tolist(),
        },
        "cell_data": cell_data(final),
        "initial": {
            "points": pts(first),
            "triangles": first.mesh.triangles.tolist(),
            "cell_data": cell_data(first),
        },
        "summary": {
            "initial": first.summary,
            "swapped": result.swapped.summary,
            "smoothed": final.summary,
            "parameters": result.parameters,
            "timings": result.timings,
            "history": [asdict(h) for h in result.history],
        },
    }
    if to_lonlat is not None:
        doc["points_local"] = final.mesh.points.tolist()
        doc["crs"] = "wgs84"
    return doc


def mesh_from_document(obj: Any) -> Mesh:
    """A validated :class:`engine.Mesh` from a document holding ``points`` and ``triangles``.

    >>> doc = {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 1, 2]]}
    >>> mesh_from_document(doc).n_triangles
    1
    """
    if not isinstance(obj, dict) or "points" not in obj or "triangles" not in obj:
        raise InvalidMesh('a mesh needs "points" and "triangles"')
    pts = obj["points_local"] if "points_local" in obj else obj["points"]
    return validate_mesh(pts, obj["triangles"])
