"""VTU (ParaView) and Gmsh through meshio: node fitness as point data, triangle figures as cell
data, and a document's tagged ``lines`` as line cells. meshio reads and writes files, not buffers,
so both go through a temporary file.

In VTU, line cells carry ``tag`` and triangles ``region`` (ids; VTU has no name table). In MSH
(Gmsh 4.1 by default, 2.2 with ``version=2.2``) every tag is a named physical curve and every
region a named physical surface, as a solver reading it with meshio or Gmsh expects.

>>> doc = {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 1, 2]],
...        "cell_data": {"quality": [0.87]}, "point_data": {"fitness": [1.0, 0.5, 0.25]}}
>>> back = meshio_reader("vtu", ".vtu")(meshio_writer("vtu", ".vtu")(StoredResult(doc=doc), {}))
>>> back["points"], back["triangles"], back["cell_data"], back["point_data"]["fitness"]
([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], [[0, 1, 2]], {'quality': [0.87]}, [1.0, 0.5, 0.25])
"""

from __future__ import annotations

import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .registry import Reader, ReadError, StoredResult, WriteError, Writer
from .tagged import TaggedCells, read_tags, tagged_cells

__all__ = ["MSH_VERSIONS", "meshio_reader", "meshio_writer", "msh_writer"]

#: meshio's bookkeeping fields, which are not figures of the mesh.
_GMSH_TAGS = ("gmsh:physical", "gmsh:geometrical", "gmsh:dim_tags")
#: The ``version`` option of MSH -> meshio's name of the format (the first is the default).
_MESHIO_MSH = {"4.1": "gmsh", "2.2": "gmsh22"}
MSH_VERSIONS = tuple(_MESHIO_MSH)


def _write(mesh: Any, suffix: str, file_format: str, **kwargs: Any) -> bytes:
    import meshio

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"mesh{suffix}"
        try:
            meshio.write(path, mesh, file_format=file_format, **kwargs)
        except (ValueError, TypeError, KeyError) as exc:
            raise WriteError(f"cannot write {file_format}: {exc}") from None
        return path.read_bytes()


def _point_data(doc: Mapping[str, Any]) -> dict[str, Any]:
    return {k: np.asarray(v, dtype=np.float64) for k, v in doc.get("point_data", {}).items()}


def meshio_writer(file_format: str, suffix: str, **kwargs: Any) -> Writer:
    """A writer of ``file_format`` (meshio's name for it), keyword arguments to ``meshio.write``."""

    def write(result: StoredResult, options: Mapping[str, str]) -> bytes:
        import meshio  # heavy: imported only when a file is written

        cells = tagged_cells(result.doc, by_group=False)
        mesh = meshio.Mesh(
            cells.points, cells.blocks, point_data=_point_data(result.doc), cell_data=cells.data
        )
        return _write(mesh, suffix, file_format, **kwargs)

    return write


def msh_writer() -> Writer:
    """A Gmsh writer (binary: meshio 5.3's ASCII writer prints numpy 2 scalars as
    ``np.float64(...)``) with one block per tag and per region, so each is a physical group."""

    def write(result: StoredResult, options: Mapping[str, str]) -> bytes:
        import meshio

        version = options.get("version", MSH_VERSIONS[0])
        if version not in MSH_VERSIONS:
            raise WriteError(
                f"unknown MSH version {version!r}; choose one of {', '.join(MSH_VERSIONS)}",
                "version",
            )
        cells = tagged_cells(result.doc, by_group=True)
        data = _gmsh_data(cells, version)
        point_data = _point_data(result.doc)
        if version == "4.1":  # 4.1 places every node on an entity (a tag's curve, a surface)
            point_data["gmsh:dim_tags"] = cells.dim_tags
        mesh = meshio.Mesh(
            cells.points,
            cells.blocks,
            point_data=point_data,
            cell_data=data,
            field_data={k: np.asarray(v) for k, v in cells.groups.items()},
        )
        return _write(mesh, ".msh", _MESHIO_MSH[version], binary=True)

    return write


def _gmsh_data(cells: TaggedCells, version: str) -> dict[str, list[Any]]:
    data = dict(cells.data)
    for name in ("tag", "region"):  # the physical groups carry them
        data.pop(name, None)
    if version == "2.2" and len(cells.blocks) > 1:
        # meshio 5.3 reads 2.2 element data back wrongly when there are several blocks: keep
        # only the groups (the 4.1 default carries the figures).
        data = {}
    return data | {"gmsh:physical": cells.physical, "gmsh:geometrical": cells.physical}


def meshio_reader(file_format: str, suffix: str) -> Reader:
    """A reader of ``file_format`` (its meshio module's name): triangles, their cell data, the
    points they use, and tagged lines with their tags and regions when the file has them."""

    def read(data: bytes) -> dict[str, Any]:
        import meshio

        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / f"mesh{suffix}"
            path.write_bytes(data)
            try:  # the format's own reader: meshio.read prints a failure and exits the interpreter
                mesh = getattr(meshio, file_format).read(str(path))
            except Exception as exc:  # meshio raises whatever its parsers raise
                raise ReadError(f"not a {file_format} file: {exc or type(exc).__name__}") from None
        tris = mesh.get_cells_type("triangle")
        if not len(tris):
            raise ReadError(f"the {file_format} file holds no triangles")
        # Files from other tools also hold nodes of lines and vertices: keep those in triangles.
        used, tris = np.unique(tris, return_inverse=True)
        cells = {
            name: np.asarray(mesh.get_cell_data(name, "triangle"), dtype=np.float64).tolist()
            for name in mesh.cell_data
            if name not in _GMSH_TAGS and name != "tag"
        }
        nodes = {
            name: np.asarray(values, dtype=np.float64)[used].tolist()
            for name, values in mesh.point_data.items()
            if name not in _GMSH_TAGS
        }
        doc = {
            "points": np.asarray(mesh.points[used, :2], dtype=np.float64).tolist(),
            "triangles": tris.reshape(-1, 3).tolist(),
            "point_data": nodes,
            "cell_data": cells,
        }
        read_tags(mesh, used, doc)
        return doc

    return read
