"""Result formats: a registry of renderers from a stored mesh document to bytes.

``json`` is the document as stored; ``geojson`` a FeatureCollection of triangles carrying their
quality figures; ``vtu`` (ParaView) and ``msh`` (Gmsh 2.2, binary) are written by meshio with node
fitness as point data and triangle quality as cell data. ``svg`` and ``png`` are pictures drawn by
:mod:`service.render`; their query options (``color``, ``compare``, ``width``...) are read there.

>>> sorted(FORMATS)
['geojson', 'json', 'msh', 'png', 'svg', 'vtu']
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Literal

import numpy as np
import orjson

from .problems import Problem
from .render import PictureError, PictureOptions, render_picture

__all__ = ["FORMATS", "ResultFormat", "StoredResult", "register_format"]


class StoredResult:
    """A result document: its JSON bytes, parsed on first use."""

    def __init__(self, raw: bytes) -> None:
        self.raw = raw

    @cached_property
    def doc(self) -> dict[str, Any]:
        value: dict[str, Any] = orjson.loads(self.raw)
        return value


#: ``render(result, options) -> bytes``; options are the request's query parameters.
Renderer = Callable[[StoredResult, Mapping[str, str]], bytes]


@dataclass(frozen=True)
class ResultFormat:
    name: str  #: the ``f`` query value
    media_type: str
    extension: str  #: of the download's file name
    render: Renderer
    description: str = ""


#: Formats by ``f`` value.
FORMATS: dict[str, ResultFormat] = {}


def register_format(fmt: ResultFormat) -> ResultFormat:
    """Add (or replace) a result format."""
    FORMATS[fmt.name] = fmt
    return fmt


def _json(result: StoredResult, options: Mapping[str, str]) -> bytes:
    return result.raw


def _geojson(result: StoredResult, options: Mapping[str, str]) -> bytes:
    doc = result.doc
    pts = doc["points"]
    cells = doc.get("cell_data", {})
    names = list(cells)
    features = []
    for t, tri in enumerate(doc["triangles"]):
        ring = [pts[tri[0]], pts[tri[1]], pts[tri[2]], pts[tri[0]]]
        props: dict[str, Any] = {"triangle": t}
        props.update((name, cells[name][t]) for name in names)
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Polygon", "coordinates": [ring]},
                "properties": props,
            }
        )
    return orjson.dumps({"type": "FeatureCollection", "features": features})


def _meshio(file_format: str, suffix: str, **kwargs: Any) -> Renderer:
    def render(result: StoredResult, options: Mapping[str, str]) -> bytes:
        import meshio  # optional (the formats extra); only needed here

        doc = result.doc
        pts = np.asarray(doc["points"], dtype=np.float64)
        pts = np.column_stack([pts, np.zeros(len(pts))])  # meshio's 2-D writers want z
        tris = np.asarray(doc["triangles"], dtype=np.int64)
        cell_data: dict[str, list[Any]] = {
            k: [np.asarray(v, dtype=np.float64)] for k, v in doc["cell_data"].items()
        }
        if file_format == "gmsh22":
            ones = np.ones(len(tris), dtype=np.int64)  # one physical and geometrical entity
            cell_data |= {"gmsh:physical": [ones], "gmsh:geometrical": [ones]}
        point_data = {
            k: np.asarray(v, dtype=np.float64) for k, v in doc.get("point_data", {}).items()
        }
        mesh = meshio.Mesh(pts, [("triangle", tris)], point_data=point_data, cell_data=cell_data)
        with tempfile.TemporaryDirectory() as tmp:  # meshio writes files, not buffers
            path = Path(tmp) / f"mesh{suffix}"
            meshio.write(path, mesh, file_format=file_format, **kwargs)
            return path.read_bytes()

    return render


register_format(ResultFormat("json", "application/json", ".json", _json, "the mesh document"))
register_format(
    ResultFormat(
        "geojson",
        "application/geo+json",
        ".geojson",
        _geojson,
        "a FeatureCollection of triangles with their quality figures",
    )
)
register_format(
    ResultFormat("vtu", "application/xml", ".vtu", _meshio("vtu", ".vtu"), "VTK (ParaView)")
)
register_format(
    ResultFormat(
        "msh",
        "application/octet-stream",
        ".msh",
        # Binary: meshio 5.3's ASCII writer prints numpy 2 scalars as "np.float64(...)".
        _meshio("gmsh22", ".msh", binary=True),
        "Gmsh 2.2 (binary)",
    )
)


def _picture(kind: Literal["png", "svg"]) -> Renderer:
    def render(result: StoredResult, options: Mapping[str, str]) -> bytes:
        try:
            return render_picture(result.doc, kind, PictureOptions.from_query(options))
        except PictureError as exc:
            raise Problem(
                400, exc.message, kind="invalid-parameter", parameter=exc.parameter
            ) from None

    return render


_PICTURE_OPTIONS = (
    "triangles coloured by quality; options color=quality|fitness|radius_ratio|min_angle|"
    "max_angle, compare=1 (before and after with quality histograms), width, height, worst, "
    "edges, vmin, vmax"
)
register_format(
    ResultFormat(
        "svg", "image/svg+xml", ".svg", _picture("svg"), f"SVG picture: {_PICTURE_OPTIONS}"
    )
)
register_format(
    ResultFormat("png", "image/png", ".png", _picture("png"), f"PNG picture: {_PICTURE_OPTIONS}")
)
