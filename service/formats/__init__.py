"""Result formats: one table of readers and writers keyed by name and extension (as meshio's).

``json`` is the mesh document as stored; ``geojson`` a FeatureCollection of triangles carrying
their quality figures and region, and of tagged lines; ``vtu`` (ParaView) and ``msh`` (Gmsh 4.1,
or 2.2 with ``version=2.2``; binary) go through meshio with node fitness as point data, triangle
figures as cell data and tagged lines as line cells (physical groups in MSH); ``svg`` and
``png`` are pictures drawn by :mod:`service.render`, whose query options (``color``,
``compare``, ``width``...) are read there. ``json``, ``vtu`` and ``msh`` can also be read back.

>>> sorted(FORMATS)
['geojson', 'json', 'msh', 'png', 'svg', 'vtu']
>>> format_of("out.vtu").media_type, [f.name for f in FORMATS.values() if f.reader]
('application/xml', ['json', 'vtu', 'msh'])
"""

from __future__ import annotations

from .meshio_io import meshio_reader, meshio_writer, msh_writer
from .native import read_json, write_geojson, write_json
from .pictures import PICTURE_OPTIONS, picture_writer
from .registry import (
    EXTENSIONS,
    FORMATS,
    FormatError,
    Reader,
    ReadError,
    ResultFormat,
    StoredResult,
    UnknownFormat,
    WriteError,
    Writer,
    format_named,
    format_of,
    register_format,
)

__all__ = [  # the table, its lookups and its errors (registry.py's own list)
    "EXTENSIONS",
    "FORMATS",
    "FormatError",
    "ReadError",
    "Reader",
    "ResultFormat",
    "StoredResult",
    "UnknownFormat",
    "WriteError",
    "Writer",
    "format_named",
    "format_of",
    "register_format",
]

register_format(
    "json",
    [".json"],
    "application/json",
    reader=read_json,
    writer=write_json,
    description="the mesh document",
)
register_format(
    "geojson",
    [".geojson"],
    "application/geo+json",
    writer=write_geojson,
    description="a FeatureCollection of triangles with their quality figures",
)
register_format(
    "vtu",
    [".vtu"],
    "application/xml",
    reader=meshio_reader("vtu", ".vtu"),
    writer=meshio_writer("vtu", ".vtu"),
    description="VTK (ParaView)",
)
register_format(
    "msh",
    [".msh"],
    "application/octet-stream",
    reader=meshio_reader("gmsh", ".msh"),
    writer=msh_writer(),
    description="Gmsh 4.1 (binary; version=2.2 for 2.2) with a named physical group per tag "
    "and region",
)
register_format(
    "svg",
    [".svg"],
    "image/svg+xml",
    writer=picture_writer("svg"),
    description=f"SVG picture: {PICTURE_OPTIONS}",
)
register_format(
    "png",
    [".png"],
    "image/png",
    writer=picture_writer("png"),
    description=f"PNG picture: {PICTURE_OPTIONS}",
)
