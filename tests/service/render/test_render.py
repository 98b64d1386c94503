"""Pictures of meshes (service.render): sizes, colours of the colour map, options, errors."""

from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from matplotlib import colormaps
from matplotlib.colors import Normalize, to_hex
from PIL import Image

import engine
from service.cli import main
from service.document import result_document
from service.render import (
    COLORMAP,
    METRICS,
    WORST_COLOR,
    PictureError,
    PictureOptions,
    color_range,
    render_picture,
)

from ..conftest import SQUARE, assert_problem, submit, wait_for

DATA = Path(__file__).resolve().parents[2] / "data" / "cases"


def _jittered_document(width: float = 2.0, size: float = 0.25, seed: int = 3) -> dict[str, Any]:
    """A mesh document of a rectangle whose interior nodes were shaken: a wide range of
    qualities, and an ``initial`` mesh to compare with (swapping changes it)."""
    region = engine.make_region([([[0, 0], [width, 0], [width, 1], [0, 1]], [])])
    none = engine.SmoothingParams("none")
    meshed = engine.mesh_then_smooth(region, engine.PipelineParams(engine.SizingParams(size),
                                     smoothing=none))  # fmt: skip
    mesh = meshed.smoothed.mesh
    rng = np.random.default_rng(seed)
    moved = mesh.points.copy()
    inner = ~mesh.boundary_nodes
    moved[inner] += rng.uniform(-0.3, 0.3, (int(inner.sum()), 2)) * size
    shaken = engine.Mesh(moved, mesh.triangles)
    assert engine.assess_mesh(shaken).summary["inverted"] == 0
    return result_document(engine.smooth_mesh(shaken, none, swap=True))


@pytest.fixture(scope="module")
def doc() -> dict[str, Any]:
    return _jittered_document()


def _viridis_lut() -> np.ndarray:
    return np.round(colormaps[COLORMAP](np.linspace(0, 1, 256))[:, :3] * 255)


def _colour_map_hits(rgb: np.ndarray, tolerance: float = 3.0) -> tuple[float, int]:
    """Share of pixels that are colours of the map, and how many map entries they span."""
    lut = _viridis_lut()
    pixels = rgb.reshape(-1, 3).astype(np.float64)
    unique, counts = np.unique(pixels, axis=0, return_counts=True)
    dist = np.linalg.norm(unique[:, None, :] - lut[None, :, :], axis=2)
    near = dist.min(axis=1) <= tolerance
    entries = np.unique(dist.argmin(axis=1)[near])
    return float(counts[near].sum() / pixels.shape[0]), int(entries.size)


def _hex_rgb(colour: str) -> np.ndarray:
    return np.array([int(colour[i : i + 2], 16) for i in (1, 3, 5)], dtype=np.float64)


def test_png_has_the_requested_size_and_the_colour_map(doc: dict[str, Any]) -> None:
    png = render_picture(doc, "png", PictureOptions(width=640, height=480))
    image = Image.open(io.BytesIO(png))
    assert image.format == "PNG"
    assert image.size == (640, 480)
    rgb = np.asarray(image.convert("RGB"))
    share, entries = _colour_map_hits(rgb)
    assert share > 0.15, share  # the mesh and the colour bar
    assert entries > 60, entries  # many qualities: many colours of the map
    red = np.linalg.norm(rgb.reshape(-1, 3) - _hex_rgb(WORST_COLOR), axis=1) < 40
    assert red.sum() > 20  # the worst triangles are outlined


def test_default_size_follows_the_mesh_shape(doc: dict[str, Any]) -> None:
    wide = Image.open(io.BytesIO(render_picture(doc, "png")))
    assert wide.width == 1200
    assert wide.height < 0.8 * wide.width  # a 2:1 rectangle
    compare = Image.open(io.BytesIO(render_picture(doc, "png", PictureOptions(compare=True))))
    assert compare.width == 1600


def test_svg_has_the_size_in_pixels_and_the_triangles_colours(doc: dict[str, Any]) -> None:
    svg = render_picture(doc, "svg", PictureOptions(width=900, height=500))
    root = ET.fromstring(svg)
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    assert (root.get("width"), root.get("height")) == ("900px", "500px")
    text = svg.decode()
    q = np.asarray(doc["cell_data"]["quality"])
    lo, hi = color_range(METRICS["quality"], [q])
    cmap, norm = colormaps[COLORMAP], Normalize(lo, hi)
    fills = set(re.findall(r"fill: (#[0-9a-f]{6})", text))
    expected = {to_hex(cmap(norm(v))) for v in q}
    assert len(expected & fills) > 0.9 * len(expected)  # small meshes are vector polygons
    assert "triangle quality (1 = equilateral)" in text  # matplotlib keeps text as comments
    assert f"{q.size:,} triangles" in text


def test_fitness_colouring_names_its_metric(doc: dict[str, Any]) -> None:
    svg = render_picture(doc, "svg", PictureOptions(color="fitness")).decode()
    assert "node fitness" in svg
    assert "triangle quality (1 = equilateral)" not in svg


def test_compare_shows_before_and_after_with_histograms(doc: dict[str, Any]) -> None:
    svg = render_picture(doc, "svg", PictureOptions(compare=True)).decode()
    for words in ("before: as meshed", "after: swapped", "bars: before", "bars: after"):
        assert words in svg
    assert svg.count("triangle quality") >= 3  # two histogram axes and the colour bar


def test_big_meshes_are_rasterized_in_svg() -> None:
    doc = _jittered_document(size=0.02)
    assert len(doc["triangles"]) > 5000
    svg = render_picture(doc, "svg", PictureOptions(width=600, height=400)).decode()
    assert "<image" in svg  # the mesh, as one embedded picture
    assert len(svg) < 2_000_000


@pytest.mark.parametrize(
    ("query", "parameter"),
    [
        ({"color": "colour"}, "color"),
        ({"compare": "maybe"}, "compare"),
        ({"width": "12"}, "width"),
        ({"width": "wide"}, "width"),
        ({"vmin": "nan"}, "vmin"),
        ({"vmin": "0.5", "vmax": "0.5"}, "vmax"),
    ],
)
def test_bad_options_name_their_parameter(query: dict[str, str], parameter: str) -> None:
    with pytest.raises(PictureError) as exc:
        PictureOptions.from_query(query)
    assert exc.value.parameter == parameter


def test_compare_needs_an_initial_mesh(doc: dict[str, Any]) -> None:
    bare = {k: doc[k] for k in ("points", "triangles", "cell_data", "point_data")}
    render_picture(bare, "png", PictureOptions(width=300, height=200))
    with pytest.raises(PictureError, match="no initial mesh") as exc:
        render_picture(bare, "png", PictureOptions(compare=True))
    assert exc.value.parameter == "compare"


def test_colour_range_starts_below_the_worst_value() -> None:
    quality = METRICS["quality"]
    assert color_range(quality, [np.array([0.86, 1.0])]) == (0.8, 1.0)
    assert color_range(quality, [np.array([0.81, 1.0])]) == (0.7, 1.0)  # room below the worst
    assert color_range(quality, [np.array([1.0])]) == (0.9, 1.0)  # a perfect mesh
    assert color_range(quality, [np.array([0.86]), np.array([0.36])]) == (0.3, 1.0)
    assert color_range(METRICS["min_angle"], [np.array([23.0, 60.0])]) == (20.0, 60.0)


def test_cli_mesh_writes_pictures(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for suffix, magic in ((".png", b"\x89PNG"), (".svg", b"<?xml")):
        out = tmp_path / f"l{suffix}"
        args = ["mesh", str(DATA / "l_shape.geojson"), "--size", "0.1", "--smooth", "none"]
        assert main([*args, "-o", str(out)]) == 0
        assert out.read_bytes().startswith(magic)
    assert capsys.readouterr().err == ""  # not a terminal: no progress bar


@pytest.mark.anyio
async def test_results_as_pictures_through_the_api(client: httpx.AsyncClient) -> None:
    inputs = {"boundary": SQUARE, "size": 0.2, "smoothing": {"method": "none"}}
    job = await submit(client, "mesh", inputs)
    assert (await wait_for(client, job["jobID"]))["status"] == "successful"
    url = f"/jobs/{job['jobID']}/results"
    r = await client.get(url, params={"f": "png", "width": "500", "height": "400"})
    assert r.status_code == 200, r.text
    assert r.headers["content-type"] == "image/png"
    assert r.headers["content-disposition"] == f'inline; filename="{job["jobID"]}.png"'
    assert Image.open(io.BytesIO(r.content)).size == (500, 400)
    r = await client.get(url, params={"f": "svg", "compare": "1", "color": "fitness"})
    assert r.status_code == 200, r.text
    assert r.headers["content-type"].startswith("image/svg+xml")
    assert "before: as meshed" in r.text
    problem = assert_problem(
        await client.get(url, params={"f": "png", "color": "beauty"}), 400, "invalid-parameter"
    )
    assert problem["parameter"] == "color"
    assert "beauty" in problem["detail"]

    mesh = {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 1, 2]]}
    quality = await submit(client, "quality", {"mesh": mesh})
    assert (await wait_for(client, quality["jobID"]))["status"] == "successful"
    url = f"/jobs/{quality['jobID']}/results"
    assert (await client.get(url, params={"f": "png"})).status_code == 200
    problem = assert_problem(await client.get(url, params={"f": "png", "compare": "1"}), 400)
    assert problem["parameter"] == "compare"
