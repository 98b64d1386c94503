"""VTU (ParaView) and Gmsh 2.2 through meshio: node fitness as point data, triangle figures as
cell data. meshio reads and writes files, not buffers, so both go through a temporary file.

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

__all__ = ["meshio_reader", "meshio_writer"]

#: meshio's bookkeeping fields, which are not figures of the mesh.
_GMSH_TAGS = ("gmsh:physical", "gmsh:geometrical", "gmsh:dim_tags")


def meshio_writer(file_format: str, suffix: str, **kwargs: Any) -> Writer:
    """A writer of ``file_format`` (meshio's name for it), keyword arguments to ``meshio.write``."""

    def write(result: StoredResult, options: Mapping[str, str]) -> bytes:
        import meshio  # heavy: imported only when a file is written

        doc = result.doc
        pts = np.asarray(doc["points"], dtype=np.float64).reshape(-1, 2)
        pts = np.column_stack([pts, np.zeros(len(pts))])  # meshio's 2-D writers want z
        tris = np.asarray(doc["triangles"], dtype=np.int64).reshape(-1, 3)
        cell_data: dict[str, list[Any]] = {
            k: [np.asarray(v, dtype=np.float64)] for k, v in doc.get("cell_data", {}).items()
        }
        if file_format == "gmsh22":
            ones = np.ones(len(tris), dtype=np.int64)  # one physical and geometrical entity
            cell_data |= {"gmsh:physical": [ones], "gmsh:geometrical": [ones]}
        point_data = {
            k: np.asarray(v, dtype=np.float64) for k, v in doc.get("point_data", {}).items()
        }
        mesh = meshio.Mesh(pts, [("triangle", tris)], point_data=point_data, cell_data=cell_data)
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / f"mesh{suffix}"
            try:
                meshio.write(path, mesh, file_format=file_format, **kwargs)
            except (ValueError, TypeError, KeyError) as exc:
                raise WriteError(f"cannot write {file_format}: {exc}") from None
            return path.read_bytes()

    return write


def meshio_reader(file_format: str, suffix: str) -> Reader:
    """A reader of ``file_format`` (its meshio module's name): triangles, their cell data and
    the points they use."""

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
            if name not in _GMSH_TAGS
        }
        nodes = {
            name: np.asarray(values, dtype=np.float64)[used].tolist()
            for name, values in mesh.point_data.items()
            if name not in _GMSH_TAGS
        }
        return {
            "points": np.asarray(mesh.points[used, :2], dtype=np.float64).tolist(),
            "triangles": tris.reshape(-1, 3).tolist(),
            "point_data": nodes,
            "cell_data": cells,
        }

    return read
