"""A mesh document's triangles and tagged lines as meshio cell blocks, and back.

Writers get one :class:`TaggedCells`: cell blocks (triangles, then lines), per-block cell data
(triangle figures are NaN on lines; ``tag`` is 0 on triangles and ``region`` 0 on lines), the
physical id of every cell, Gmsh's name table (``name -> [id, dim]``) and the entity of each node.

>>> doc = {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 1, 2]],
...        "cell_data": {"region": [1]}, "regions": {"plate": 1},
...        "lines": [[0, 1], [1, 2], [2, 0]], "line_data": {"tag": [1, 2, 2]},
...        "tags": {"bottom": 1, "rest": 2}}
>>> cells = tagged_cells(doc, by_group=True)
>>> [(kind, len(c)) for kind, c in cells.blocks], cells.groups
([('triangle', 1), ('line', 1), ('line', 2)], {'bottom': [1, 1], 'rest': [2, 1], 'plate': [1, 2]})
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["TaggedCells", "read_tags", "tagged_cells"]

IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class TaggedCells:
    """What meshio needs to write a document's cells with their tags and regions."""

    points: NDArray[np.float64]  #: (n, 3), z = 0 (meshio's 2-D writers want z)
    blocks: list[tuple[str, IntArray]]  #: ("triangle" | "line", cells)
    data: dict[str, list[NDArray[Any]]]  #: per-block cell data
    physical: list[IntArray]  #: per-block region (triangles) or tag (lines) ids
    groups: dict[str, list[int]]  #: Gmsh physical names: name -> [id, dim]
    dim_tags: IntArray  #: (n, 2) the (dim, entity) of each node; entity = the group's id


def _split(cells: IntArray, ids: IntArray, by_group: bool) -> list[IntArray]:
    """Indices of ``cells`` per block: one block, or one per id (in id order)."""
    if not by_group:
        return [np.arange(len(cells))]
    return [np.flatnonzero(ids == i) for i in np.unique(ids)]


def tagged_cells(doc: Mapping[str, Any], *, by_group: bool) -> TaggedCells:
    """The blocks of ``doc``; ``by_group`` gives each region and tag a block of its own (Gmsh
    gives a block a single physical group)."""
    pts = np.asarray(doc["points"], dtype=np.float64).reshape(-1, 2)
    tris = np.asarray(doc["triangles"], dtype=np.int64).reshape(-1, 3)
    figures = dict(doc.get("cell_data", {}))
    region = np.asarray(figures.pop("region", np.ones(len(tris))), dtype=np.int64)
    lines = np.asarray(doc.get("lines", []), dtype=np.int64).reshape(-1, 2)
    tag = np.asarray(doc.get("line_data", {}).get("tag", np.ones(len(lines))), dtype=np.int64)
    blocks: list[tuple[str, IntArray]] = []
    data: dict[str, list[NDArray[Any]]] = {k: [] for k in figures}
    has_tags = "region" in doc.get("cell_data", {}) or len(lines) > 0
    if has_tags:
        data |= {"region": [], "tag": []}
    physical: list[IntArray] = []
    for kind, cells, ids in (("triangle", tris, region), ("line", lines, tag)):
        for pick in _split(cells, ids, by_group) if len(cells) else []:
            blocks.append((kind, cells[pick]))
            physical.append(ids[pick])
            for k, v in figures.items():
                col = np.asarray(v, dtype=np.float64)[pick] if kind == "triangle" else None
                data[k].append(col if col is not None else np.full(len(pick), np.nan))
            if has_tags:
                zero = np.zeros(len(pick), dtype=np.int64)
                data["region"].append(ids[pick] if kind == "triangle" else zero)
                data["tag"].append(ids[pick] if kind == "line" else zero)
    groups = {str(k): [int(v), 1] for k, v in doc.get("tags", {}).items()}
    for k, v in doc.get("regions", {}).items():
        groups[str(k) if k not in groups else f"{k} (region)"] = [int(v), 2]
    return TaggedCells(
        points=np.column_stack([pts, np.zeros(len(pts))]),
        blocks=blocks,
        data=data,
        physical=physical,
        groups=groups,
        dim_tags=_node_entities(len(pts), tris, region, lines, tag),
    )


def _node_entities(
    n: int, tris: IntArray, region: IntArray, lines: IntArray, tag: IntArray
) -> IntArray:
    """Each node on the surface of a triangle holding it, or on the curve of a line holding
    it; smaller tags are placed last so that short runs (one edge between two others) keep
    nodes of their own."""
    dim_tags = np.zeros((n, 2), dtype=np.int64)
    dim_tags[tris.ravel()] = np.column_stack([np.full(tris.size, 2), np.repeat(region, 3)])
    ids, counts = np.unique(tag, return_counts=True)
    for t in ids[np.argsort(-counts, kind="stable")]:
        dim_tags[lines[tag == t].ravel()] = [1, t]
    return dim_tags


def read_tags(mesh: Any, used: IntArray, doc: dict[str, Any]) -> None:
    """Add ``lines``, ``line_data.tag``, ``tags``, ``regions`` and ``cell_data.region`` found in
    a meshio ``mesh`` to ``doc`` (whose points are ``mesh.points[used]``)."""
    names = {str(k): np.asarray(v).tolist() for k, v in mesh.field_data.items()}
    tags = {k: int(v[0]) for k, v in names.items() if len(v) == 2 and v[1] == 1}
    regions = {k.removesuffix(" (region)"): int(v[0]) for k, v in names.items() if v[1:] == [2]}
    key = "gmsh:physical" if "gmsh:physical" in mesh.cell_data else "tag"
    if key == "gmsh:physical" and regions:  # physical surfaces are regions when named
        region = mesh.get_cell_data("gmsh:physical", "triangle")
        doc["cell_data"]["region"] = np.asarray(region, dtype=np.int64).tolist()
    elif "region" in doc["cell_data"]:
        doc["cell_data"]["region"] = np.asarray(doc["cell_data"]["region"], dtype=np.int64).tolist()
    lines = mesh.get_cells_type("line")
    if len(lines) and key in mesh.cell_data:
        tag = np.asarray(mesh.get_cell_data(key, "line"), dtype=np.int64)
        pos = np.clip(np.searchsorted(used, lines), 0, len(used) - 1)
        keep = (used[pos] == lines).all(axis=1)  # lines of nodes no triangle uses are dropped
        doc["lines"] = pos[keep].tolist()
        doc["line_data"] = {"tag": tag[keep].tolist()}
    if tags:
        doc["tags"] = tags
    if regions:
        doc["regions"] = regions
