"""The web viewer in a real browser: headless Chromium against a real ``evomesh serve``.

Screenshots are saved under ``test-artifacts/`` (git-ignored) for people to look at.
"""

from __future__ import annotations

import io
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from matplotlib import colormaps
from PIL import Image

import engine
from tests.conftest import DATA

from .browser import Browser, chromium_path
from .server import Server

pytestmark = pytest.mark.e2e

ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts"
#: Smoothing of the browser's jobs: the GA when the engine has it, else none (fast either way).
METHOD = "ga" if "ga" in engine.SMOOTHERS else "none"


@pytest.fixture
def server(tmp_path: Path) -> Iterator[Server]:
    s = Server(tmp_path / "data", workers=1)
    yield s
    s.stop()


def browser_session(tmp_path: Path, width: int = 1440, height: int = 900) -> Iterator[Browser]:
    """A browser of a window size for a test, which must leave no console errors."""
    assert chromium_path(), "chromium is not installed: `make test` installs it (APT_PACKAGES)"
    with Browser(tmp_path / "profile", width=width, height=height, timeout=60) as b:
        yield b
        errors = b.console_errors()
        assert not errors, errors


@pytest.fixture
def browser(tmp_path: Path) -> Iterator[Browser]:
    yield from browser_session(tmp_path)


def _q(selector: str) -> str:
    """The JavaScript expression of the element a CSS selector finds."""
    return f"document.querySelector({json.dumps(selector)})"


def _rect(b: Browser, selector: str) -> dict[str, float]:
    rect: dict[str, float] = b.evaluate(f"{_q(selector)}.getBoundingClientRect().toJSON()")
    return rect


def _click(b: Browser, selector: str) -> None:
    """A real mouse click in the middle of an element."""
    r = _rect(b, selector)
    b.click(r["x"] + r["width"] / 2, r["y"] + r["height"] / 2)


def _paste(b: Browser, selector: str, text: str) -> None:
    """Focus a field, select what is there, and insert text as a paste does."""
    b.evaluate(f"{_q(selector)}.focus(); {_q(selector)}.select()")
    b.call("Input.insertText", text=text)


def _choose(b: Browser, selector: str, value: str) -> None:
    b.evaluate(f"{_q(selector)}.value = {json.dumps(value)}")
    b.evaluate(f"{_q(selector)}.dispatchEvent(new Event('change'))")


def _canvas_pixels(b: Browser, name: str) -> np.ndarray:
    """The mesh canvas as the screen shows it (RGB), from a screenshot kept as an artifact."""
    png = b.screenshot(ARTIFACTS / name)
    r = _rect(b, "#mesh-canvas")
    image = Image.open(io.BytesIO(png)).convert("RGB")
    box = (
        int(r["x"]) + 2,
        int(r["y"]) + 2,
        int(r["x"] + r["width"]) - 2,
        int(r["y"] + r["height"]) - 2,
    )
    return np.asarray(image.crop(box))


def _colour_map_share(rgb: np.ndarray) -> tuple[float, int]:
    """Share of pixels that are viridis colours, and how many entries of the map they span."""
    lut = np.round(colormaps["viridis"](np.linspace(0, 1, 256))[:, :3] * 255)
    pixels = rgb.reshape(-1, 3).astype(np.float64)
    unique, counts = np.unique(pixels, axis=0, return_counts=True)
    dist = np.linalg.norm(unique[:, None, :] - lut[None, :, :], axis=2)
    near = dist.min(axis=1) <= 6
    return float(counts[near].sum() / len(pixels)), int(np.unique(dist.argmin(axis=1)[near]).size)


def _shown(value: Any, kind: str) -> str:
    """A summary figure formatted as the page formats it (summary.js, formatValue)."""
    if value is None:
        return "\u2013"  # an en dash
    if kind == "int":
        return f"{round(value):,}"
    if kind == "q":
        return f"{value:.3f}"
    if kind == "deg":
        return f"{value:.1f}°"
    return f"{100 * value:.1f}%"


_KINDS = {
    "count": "int",
    "points": "int",
    "inverted": "int",
    "min_angle/min": "deg",
    "max_angle/max": "deg",
    "share_below_30deg": "pct",
    "share_quality_ge_0.91": "pct",
}


def _dig(summary: dict[str, Any], path: str) -> Any:
    for key in path.split("/"):
        summary = summary[key]
    return summary


def test_mesh_the_l_shape_in_the_browser(server: Server, browser: Browser) -> None:
    b = browser
    # A browser asking for / gets the viewer (an API client gets the OGC landing page).
    b.goto(server.url + "/")
    assert b.evaluate("document.title") == "evomesh viewer"
    b.wait_for("document.body.dataset.ready === 'true'", timeout=30)
    methods = b.evaluate("[...document.querySelectorAll('#method option')].map(o => o.value)")
    described = server.client.get("/processes/mesh").json()["inputs"]["smoothing"]["schema"]
    assert methods == described["properties"]["method"]["enum"]  # choices come from the API

    _paste(b, "#region-text", (DATA / "cases" / "l_shape.geojson").read_text())
    b.wait_for("document.getElementById('region-status').textContent.includes('7 vertices')")
    assert b.evaluate("document.getElementById('size').value") == "0.03"  # the case's h
    _choose(b, "#method", METHOD)
    _click(b, "#submit")
    b.wait_for("document.body.dataset.jobStatus === 'successful'", timeout=120)
    job_id = b.wait_for("document.body.dataset.rendered", timeout=60)
    status = server.client.get(f"/jobs/{job_id}").json()
    assert status["status"] == "successful"
    assert b.evaluate("document.getElementById('progress-pct').textContent") == "100%"

    # The canvas shows the mesh: colours of the map, not a blank box.
    rgb = _canvas_pixels(b, "viewer-l_shape-quality.png")
    share, entries = _colour_map_share(rgb)
    assert share > 0.25, share
    assert entries >= 5, entries
    assert rgb.std() > 10

    # The summary on the page says what the API says.
    doc = server.client.get(f"/jobs/{job_id}/results").json()
    cells = json.loads(
        b.evaluate(
            "JSON.stringify([...document.querySelectorAll('#summary td[data-key]')]"
            ".map(td => [td.dataset.stage, td.dataset.key, td.textContent]))"
        )
    )
    assert len(cells) == 3 * 12  # three stages, twelve figures
    for stage, key, text in cells:
        assert text == _shown(_dig(doc["summary"][stage], key), _KINDS.get(key, "q")), (stage, key)
    assert f"seed {doc['summary']['parameters']['seed']}" in b.evaluate(
        "document.getElementById('summary').textContent"
    )  # 63-bit seeds stay exact

    # Colour by fitness; zoom in with the wheel; hover a triangle.
    _click(b, "[data-color=fitness]")
    b.wait_for("document.getElementById('legend-title').textContent === 'node fitness'")
    r = _rect(b, "#mesh-canvas")
    x, y = r["x"] + r["width"] * 0.3, r["y"] + r["height"] * 0.6
    scale = b.evaluate("window.evomesh.view.scale")
    for _ in range(3):
        b.wheel(x, y, -240)
    b.wait_for(f"window.evomesh.view.scale > {scale} * 2")
    b.call("Input.dispatchMouseEvent", type="mouseMoved", x=x, y=y)
    readout = b.wait_for(
        "(t => t.includes('triangle') && t)(document.getElementById('readout').textContent)"
    )
    assert "quality" in readout
    assert "fitness" in readout
    share, _ = _colour_map_share(_canvas_pixels(b, "viewer-l_shape-fitness-zoomed.png"))
    assert share > 0.3, share

    # Every format can be downloaded from its link.
    links = json.loads(
        b.evaluate(
            "JSON.stringify([...document.querySelectorAll('#downloads a')]"
            ".map(a => [a.dataset.format, a.href]))"
        )
    )
    assert {f for f, _ in links} == {"json", "geojson", "vtu", "msh", "svg", "png"}
    png = next(href for f, href in links if f == "png")
    r2 = httpx.get(png, timeout=60)
    assert r2.status_code == 200
    assert r2.headers["content-type"] == "image/png"

    # The job is in the list; dismissing it there deletes it.
    item = f"#jobs li[data-job='{job_id}']"
    b.wait_for(f"!!{_q(item)}")
    _click(b, f"{item} .dismiss")
    b.wait_for(f"{_q(item + ' .pill')}.textContent === 'dismissed'")
    assert server.client.get(f"/jobs/{job_id}").json()["status"] == "dismissed"


def test_draw_a_region_with_a_hole_and_see_errors(server: Server, browser: Browser) -> None:
    b = browser
    b.goto(server.url + "/viewer")
    b.wait_for("document.body.dataset.ready === 'true'", timeout=30)

    # A region with an error: the problem's title and detail are shown, and where it is.
    bowtie = {"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]}
    _paste(b, "#region-text", json.dumps(bowtie))
    _click(b, "#submit")
    error = b.wait_for("(e => !e.hidden && e.textContent)(document.getElementById('submit-error'))")
    assert "intersects itself" in error
    assert b.evaluate("window.evomesh.view.marker.x") == pytest.approx(0.5)
    b.screenshot(ARTIFACTS / "viewer-error.png")

    # Draw an outline by clicks (closed by clicking its first corner), then a hole (Enter).
    _click(b, "#draw-button")
    canvas = _rect(b, "#mesh-canvas")

    def at(x: float, y: float) -> tuple[float, float]:
        sx, sy = b.evaluate(f"window.evomesh.view.toScreen({x}, {y})")
        return canvas["x"] + sx, canvas["y"] + sy

    for corner in [(0, 0), (1, 0), (1, 0.8), (0.4, 1), (0, 1), (0, 0)]:
        b.click(*at(*corner))
    for corner in [(0.3, 0.3), (0.6, 0.3), (0.45, 0.6)]:
        b.click(*at(*corner))
    b.call(
        "Input.dispatchKeyEvent",
        type="keyDown",
        key="Enter",
        code="Enter",
        windowsVirtualKeyCode=13,
    )
    b.screenshot(ARTIFACTS / "viewer-drawing.png")
    _click(b, "#draw-button")  # done
    region = json.loads(b.evaluate("document.getElementById('region-text').value"))
    outline, hole = region["coordinates"]
    assert outline == [[0, 0], [1, 0], [1, 0.8], [0.4, 1], [0, 1], [0, 0]]
    assert sorted(map(tuple, hole[:-1])) == [(0.3, 0.3), (0.45, 0.6), (0.6, 0.3)]
    _choose(b, "#method", "none")
    _click(b, "#submit")
    job_id = b.wait_for("document.body.dataset.rendered", timeout=120)
    doc = server.client.get(f"/jobs/{job_id}/results").json()
    mesh = engine.validate_mesh(doc["points"], doc["triangles"])
    assert 0.85 < float(np.sum(engine.triangle_quality(mesh).area)) < 0.92  # 0.9 less the hole

    # The same job drawn without WebGL (canvas 2D, for browsers without it).
    b.goto(server.url + f"/viewer?renderer=canvas2d#job={job_id}")
    b.wait_for(f"document.body.dataset.rendered === '{job_id}'", timeout=60)
    assert b.evaluate("window.evomesh.view.renderer.name") == "canvas2d"
    share, entries = _colour_map_share(_canvas_pixels(b, "viewer-drawn-canvas2d.png"))
    assert share > 0.25, share
    assert entries >= 5, entries
