"""The mesh document (DESIGN.md): the native JSON form of a result, and reading meshes back."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pyproj import Transformer

from engine import METRICS, Mesh, MeshTags, Result, Snapshot, validate_mesh
from engine.errors import InvalidMesh

from .geo import normalize_longitudes, resolve_crs

__all__ = ["add_tags", "cell_data", "mesh_from_document", "plane_to_input", "result_document"]

PointMap = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def cell_data(snap: Snapshot) -> dict[str, list[float]]:
    """The ``cell_data`` of a document: each metric of :data:`engine.METRICS` per triangle."""
    return {name: snap.quality[name].tolist() for name in METRICS}


def plane_to_input(crs: Mapping[str, Any] | None) -> PointMap | None:
    """Mesh-plane points -> the input CRS, from a document's ``crs`` (rebuilt from the CRS
    names, as a worker gets them); ``None`` when the plane is the input's own coordinates.

    >>> back = plane_to_input({"input": "EPSG:4326", "mesh": "EPSG:32633", "geographic": True})
    >>> np.round(back(np.array([[500_000.0, 0.0]])), 6).tolist()
    [[15.0, 0.0]]
    """
    if not crs or crs.get("input") is None or crs.get("input") == crs.get("mesh"):
        return None
    # always_xy: lon/lat in that order whatever the CRS's axis order (GeoJSON's convention).
    back = Transformer.from_crs(resolve_crs(crs["mesh"]), resolve_crs(crs["input"]), always_xy=True)
    geographic = bool(crs.get("geographic"))

    def to_input(xy: NDArray[np.float64]) -> NDArray[np.float64]:
        x, y = back.transform(xy[:, 0], xy[:, 1], errcheck=True)
        out = np.column_stack([x, y])
        return normalize_longitudes(out) if geographic else out

    return to_input


def result_document(
    result: Result, crs: Mapping[str, Any] | None = None, tags: MeshTags | None = None
) -> dict[str, Any]:
    """The mesh document of ``result``.

    ``points``/``triangles``/``point_data``/``cell_data`` describe the final mesh; ``initial``
    holds the mesh as first meshed (before swapping and smoothing) with its own cell data, so
    clients can compare; ``summary`` holds each stage's figures, parameters, timings and the
    smoothing history. With ``crs`` (what :meth:`service.geojson.ParsedRegion.crs` gives) the
    document carries it, and when the input was lon/lat ``points`` are lon/lat and
    ``projected`` keeps the mesh-plane coordinates (metres) the figures refer to. With ``tags``
    (:func:`engine.tags.tag_mesh` of the final mesh) it holds the tagged ``lines``,
    ``line_data.tag``, ``tags``, ``regions``, ``cell_data.region`` and ``point_data.fixed``
    (:func:`add_tags`).
    """
    final, first = result.smoothed, result.initial
    to_input = plane_to_input(crs)

    def pts(snap: Snapshot) -> list[list[float]]:
        xy = snap.mesh.points
        return (to_input(xy) if to_input is not None else xy).tolist()

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
    if crs:
        doc["crs"] = dict(crs)
    if to_input is not None:
        doc["projected"] = {
            "points": final.mesh.points.tolist(),
            "initial_points": first.mesh.points.tolist(),
        }
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
    projected = obj.get("projected")
    if isinstance(projected, dict) and "points" in projected:
        pts = projected["points"]  # the plane the mesh was made in (metres for lon/lat)
    else:  # documents before version 1.1 named it points_local
        pts = obj["points_local"] if "points_local" in obj else obj["points"]
    return validate_mesh(pts, obj["triangles"])
