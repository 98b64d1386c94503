"""The mesh document (DESIGN.md): the native JSON form of a result, and reading meshes back."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np
from numpy.typing import NDArray

from engine import METRICS, Mesh, MeshTags, Result, Snapshot, validate_mesh
from engine.errors import InvalidMesh

__all__ = ["add_tags", "cell_data", "mesh_from_document", "result_document"]


def cell_data(snap: Snapshot) -> dict[str, list[float]]:
    """The ``cell_data`` of a document: each metric of :data:`engine.METRICS` per triangle."""
    return {name: snap.quality[name].tolist() for name in METRICS}


def result_document(
    result: Result,
    to_lonlat: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
    tags: MeshTags | None = None,
) -> dict[str, Any]:
    """The mesh document of ``result``.

    ``points``/``triangles``/``point_data``/``cell_data`` describe the final mesh; ``initial``
    holds the mesh as first meshed (before swapping and smoothing) with its own cell data, so
    clients can compare; ``summary`` holds each stage's figures, parameters, timings and the
    smoothing history. With ``tags`` (:func:`engine.tags.tag_mesh` of the final mesh) it holds
    the tagged ``lines``, ``line_data.tag``, ``tags``, ``regions``, ``cell_data.region`` and
    ``point_data.fixed`` (:func:`add_tags`). With ``to_lonlat`` (a region given in wgs84)
    points are lon/lat and ``points_local`` keeps the metric coordinates the figures refer to.
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
    if tags is not None:
        add_tags(doc, tags)
    if to_lonlat is not None:
        doc["points_local"] = final.mesh.points.tolist()
        doc["crs"] = "wgs84"
    return doc


def add_tags(doc: dict[str, Any], tags: MeshTags) -> None:
    """Add the tagged lines, tag and region tables, triangle regions and fixed nodes to ``doc``."""
    doc["lines"] = tags.lines.tolist()
    doc["line_data"] = {"tag": tags.line_tag.tolist()}
    doc["tags"] = dict(tags.tags)
    doc["regions"] = dict(tags.regions)
    doc["cell_data"]["region"] = tags.region.tolist()
    doc["point_data"]["fixed"] = tags.fixed.astype(int).tolist()


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
