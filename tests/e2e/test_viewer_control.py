"""The viewer draws a job's refinements and constraints over its mesh, each an overlay layer the
legend switches on and off, in a real browser against a real server."""

from __future__ import annotations

import pytest

from . import test_viewer as viewer_tests
from .browser import Browser
from .server import Server

pytestmark = pytest.mark.e2e

server = viewer_tests.server
browser = viewer_tests.browser

SQUARE = [[0, 0], [2, 0], [2, 2], [0, 2], [0, 0]]


def _open(b: Browser, server: Server, job_id: str) -> None:
    b.goto(server.url + "/viewer")
    b.wait_for("document.body.dataset.ready === 'true'", timeout=30)
    b.evaluate(f"window.evomesh.openResult({job_id!r})")
    b.wait_for(f"document.body.dataset.rendered === {job_id!r}")


def _drawn(b: Browser) -> dict[str, int]:
    drawn: dict[str, int] = b.evaluate(
        "(() => { window.evomesh.view.render(); return window.evomesh.view.controlDrawn; })()"
    )
    return drawn


def test_refinements_and_constraints_are_layers_of_the_mesh(
    server: Server, browser: Browser
) -> None:
    inputs = {
        "boundary": {"type": "Polygon", "coordinates": [SQUARE]},
        "size": 0.3,
        "smoothing": {"method": "none"},
        "refinements": [
            {"geometry": {"type": "Point", "coordinates": [0.5, 0.5]}, "size": 0.05},
            {
                "geometry": {"type": "LineString", "coordinates": [[1.2, 0.3], [1.8, 0.3]]},
                "size": 0.08,
                "growth": 1.1,
            },
        ],
        "constraints": {
            "type": "FeatureCollection",
            "features": [
                {
                    "type": "Feature",
                    "properties": {"name": "dam"},
                    "geometry": {"type": "LineString", "coordinates": [[0.3, 1.2], [1.7, 1.6]]},
                },
                {
                    "type": "Feature",
                    "properties": {},
                    "geometry": {"type": "Point", "coordinates": [1.5, 1.0]},
                },
            ],
        },
    }
    job = server.client.post("/processes/mesh/execution", json={"inputs": inputs}).json()
    assert server.wait(job["jobID"])["status"] == "successful"
    b = browser
    _open(b, server, job["jobID"])
    control = b.evaluate("window.evomesh.view.control")
    assert [r["size"] for r in control["refinements"]] == [0.05, 0.08]
    assert [g["type"] for g in control["constraints"]] == ["LineString", "Point"]
    assert control["constraints"][0]["coordinates"] == [[0.3, 1.2], [1.7, 1.6]]
    layers = b.evaluate(
        "[...document.querySelectorAll('#legend-layers button')]"
        ".map(b => [b.dataset.layer, b.textContent, b.classList.contains('on')])"
    )
    assert layers == [
        ["refinements", "refinements (2)", True],
        ["constraints", "constraints (2)", True],
    ]
    assert _drawn(b) == {"refinements": 2, "constraints": 2}
    # The constraint line is drawn on the overlay in its colour (#6a3d9a) at its middle (with
    # the worst triangles' outlines hidden: they may lie along the line).
    b.evaluate("window.evomesh.view.showWorst = false; window.evomesh.view.render()")
    sx, sy = b.evaluate("window.evomesh.view.toScreen(1.0, 1.4)")
    pixel = b.evaluate(
        "(() => { const c = window.evomesh.view.overlay; const d = window.devicePixelRatio || 1;"
        f" return Array.from(c.getContext('2d').getImageData(Math.round({sx} * d),"
        f" Math.round({sy} * d), 1, 1).data); }})()"
    )
    assert pixel[:3] == [0x6A, 0x3D, 0x9A]
    assert pixel[3] > 200
    # Each layer switches on and off alone.
    b.evaluate("document.querySelector('[data-layer=refinements]').click()")
    assert _drawn(b) == {"refinements": 0, "constraints": 2}
    assert (
        b.evaluate("document.querySelector('[data-layer=refinements]').classList.contains('on')")
        is False
    )
    b.evaluate("document.querySelector('[data-layer=constraints]').click()")
    assert _drawn(b) == {"refinements": 0, "constraints": 0}
    b.evaluate("document.querySelector('[data-layer=refinements]').click()")
    assert _drawn(b) == {"refinements": 2, "constraints": 0}


def test_a_job_without_mesh_control_shows_no_layers(server: Server, browser: Browser) -> None:
    inputs = {
        "boundary": {"type": "Polygon", "coordinates": [SQUARE]},
        "size": 0.5,
        "smoothing": {"method": "none"},
    }
    job = server.client.post("/processes/mesh/execution", json={"inputs": inputs}).json()
    assert server.wait(job["jobID"])["status"] == "successful"
    _open(browser, server, job["jobID"])
    assert browser.evaluate("document.querySelectorAll('#legend-layers button').length") == 0
    assert _drawn(browser) == {"refinements": 0, "constraints": 0}
