"""The format table: every format over the catalogue of small meshes, lookups and typed errors."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
import orjson
import pytest
from hypothesis import given, settings
from PIL import Image

from service.formats import (
    EXTENSIONS,
    FORMATS,
    ReadError,
    StoredResult,
    UnknownFormat,
    WriteError,
    format_named,
    format_of,
    register_format,
)
from service.problems import problem_for

from ...engine.random_meshes import meshes
from .format_catalogue import CATALOGUE, assert_same_mesh, document, write_read

READABLE = [f for f in FORMATS.values() if f.reader is not None]
WRITE_ONLY = [f for f in FORMATS.values() if f.reader is None]


@pytest.mark.parametrize("name", CATALOGUE)
@pytest.mark.parametrize("fmt", READABLE, ids=lambda f: f.name)
def test_every_readable_format_round_trips_the_catalogue(fmt: Any, name: str) -> None:
    doc = CATALOGUE[name]
    assert_same_mesh(write_read(fmt, doc), doc)


@settings(max_examples=15, deadline=None)
@given(mesh=meshes())
def test_meshio_formats_round_trip_any_mesh(mesh: Any) -> None:
    doc = document(mesh)
    for name in ("vtu", "msh"):
        assert_same_mesh(write_read(FORMATS[name], doc), doc)


def _check_geojson(data: bytes, doc: dict[str, Any]) -> None:
    features = orjson.loads(data)["features"]
    assert len(features) == len(doc["triangles"])
    ring = features[-1]["geometry"]["coordinates"][0]
    assert ring[0] == ring[-1] == doc["points"][doc["triangles"][-1][0]]
    assert features[-1]["properties"]["quality"] == doc["cell_data"]["quality"][-1]


def _check_png(data: bytes, doc: dict[str, Any]) -> None:
    assert Image.open(io.BytesIO(data)).size[0] == 300


def _check_svg(data: bytes, doc: dict[str, Any]) -> None:
    assert b"<svg" in data[:1000]


@pytest.mark.parametrize("name", CATALOGUE)
@pytest.mark.parametrize("fmt", WRITE_ONLY, ids=lambda f: f.name)
def test_every_write_only_format_writes_the_catalogue(fmt: Any, name: str) -> None:
    doc = CATALOGUE[name]
    data = fmt.render(StoredResult(doc=doc), {"width": "300", "height": "200"})
    checks = {"geojson": _check_geojson, "png": _check_png, "svg": _check_svg}
    checks[fmt.name](data, doc)


def test_every_format_is_found_by_name_and_each_extension() -> None:
    for fmt in FORMATS.values():
        assert format_named(fmt.name) is fmt
        assert fmt.writer is not None  # the API offers every format: each must be writable
        for ext in fmt.extensions:
            assert format_of(f"dir.d/mesh{ext.upper()}") is fmt
    assert set(EXTENSIONS) == {".json", ".geojson", ".vtu", ".msh", ".svg", ".png"}


def test_a_registered_format_is_found_and_used() -> None:
    fmt = register_format(
        "csv", [".csv", ".txt"], "text/csv", writer=lambda r, o: str(len(r.doc["points"])).encode()
    )
    try:
        assert format_of("m.txt") is fmt
        assert fmt.render(StoredResult(doc=CATALOGUE["square"]), {}) == b"4"
        with pytest.raises(UnknownFormat, match="cannot be read; use one of json, vtu, msh"):
            fmt.read(b"4")
    finally:
        del FORMATS["csv"], EXTENSIONS[".csv"], EXTENSIONS[".txt"]


def test_unknown_names_and_extensions_are_typed_errors() -> None:
    with pytest.raises(UnknownFormat, match="unknown format 'vtk'"):
        format_named("vtk")
    with pytest.raises(UnknownFormat, match=r"unsupported file format '\.vtk'"):
        format_of("mesh.vtk")
    with pytest.raises(UnknownFormat, match="cannot be read"):
        FORMATS["png"].read(b"\x89PNG")


@pytest.mark.parametrize("name", ["json", "vtu", "msh"])
def test_garbage_is_a_read_error(name: str) -> None:
    with pytest.raises(ReadError):
        FORMATS[name].read(b"\x00 not a mesh at all [")


def test_a_json_array_is_not_a_mesh_document() -> None:
    with pytest.raises(ReadError, match="JSON object, not list"):
        FORMATS["json"].read(b"[1, 2]")


def test_meshio_reader_keeps_only_the_nodes_of_triangles(tmp_path: Path) -> None:
    import meshio

    pts = np.array([[0.0, 0.0, 0.0], [9.0, 9.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    mesh = meshio.Mesh(pts, [("vertex", np.array([[1]])), ("triangle", np.array([[0, 2, 3]]))])
    meshio.write(tmp_path / "m.vtu", mesh)
    doc = FORMATS["vtu"].read((tmp_path / "m.vtu").read_bytes())
    assert doc["points"] == [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    assert doc["triangles"] == [[0, 1, 2]]


def test_a_wrong_picture_option_is_a_write_error_naming_it() -> None:
    with pytest.raises(WriteError) as exc:
        FORMATS["png"].render(StoredResult(doc=CATALOGUE["square"]), {"color": "pink"})
    assert exc.value.parameter == "color"
    doc = problem_for(exc.value).document()
    assert (doc["status"], doc["parameter"]) == (400, "color")
    assert doc["type"].endswith("invalid-parameter")


def test_a_write_error_without_an_option_is_the_servers_fault() -> None:
    doc = problem_for(WriteError("cannot write vtu: disk full")).document()
    assert doc["status"] == 500
    assert "parameter" not in doc
