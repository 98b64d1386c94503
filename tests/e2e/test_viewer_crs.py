"""The viewer's coordinate reference system choice, in a real browser against a real server.

The service does not take ``crs`` yet (it is wired in with service.geo), so these tests read the
inputs the page would send (``window.evomesh.meshInputs``) and show a lon/lat result document
served to the page in place of a real job's.
"""

from __future__ import annotations

import json
import re

import pytest

from . import test_viewer as viewer_tests
from .browser import Browser
from .server import Server

pytestmark = pytest.mark.e2e

#: A 2 x 2 degree lon/lat box across the antimeridian (RFC 7946 positions).
ACROSS_180 = {
    "type": "Polygon",
    "coordinates": [[[179, -1], [-179, -1], [-179, 1], [179, 1], [179, -1]]],
}


# The same real server and browser as the viewer's other tests.
server = viewer_tests.server
browser = viewer_tests.browser


def _set(b: Browser, selector: str, value: str, event: str) -> None:
    q = f"document.querySelector({json.dumps(selector)})"
    b.evaluate(f"{q}.value = {json.dumps(value)}; {q}.dispatchEvent(new Event('{event}'))")


def test_crs_choice_units_and_request(server: Server, browser: Browser) -> None:
    b = browser
    b.goto(server.url + "/viewer")
    b.wait_for("document.body.dataset.ready === 'true'", timeout=30)
    _set(b, "#region-text", json.dumps(ACROSS_180), "input")
    b.wait_for("document.getElementById('region-status').textContent.includes('5 vertices')")

    # Planar by default: no crs sent, sizes in the region's own units.
    assert "crs" not in b.evaluate("window.evomesh.meshInputs()")
    assert b.evaluate("document.getElementById('size-unit').textContent") == "target edge length"
    offered = b.evaluate("[...document.querySelectorAll('#crs-list option')].map(o => o.value)")
    assert "EPSG:4326" in offered
    assert "EPSG:32601" in offered  # the UTM zone of its centre (lon 180 starts zone 1)

    # Lon/lat: sent as the crs input, sizes in metres, drawn 2 degrees wide (not 358).
    _set(b, "#crs", "EPSG:4326", "change")
    b.wait_for("document.body.dataset.crs === 'geographic'")
    assert "metres" in b.evaluate("document.getElementById('size-unit').textContent")
    assert "km²" in b.evaluate("document.getElementById('region-status').textContent")
    inputs = b.evaluate("window.evomesh.meshInputs()")
    assert inputs["crs"] == "EPSG:4326"
    assert 1_000 < inputs["size"] < 50_000  # a size suggested in metres for ~49,000 km²
    x0, _, x1, _ = b.evaluate("window.evomesh.state.region.stats.box")
    assert x1 - x0 == pytest.approx(2.0, rel=1e-6)

    # Any code typed is sent as it is; a projected one labels sizes in its units.
    _set(b, "#crs", "EPSG:32660", "change")
    b.wait_for("document.body.dataset.crs === 'projected'")
    assert b.evaluate("window.evomesh.meshInputs()")["crs"] == "EPSG:32660"


def test_a_lon_lat_result_is_shown_in_lon_lat(server: Server, browser: Browser) -> None:
    # A real result, meshed as planar degrees over 179..181, then given as RFC 7946 lon/lat.
    box = [[179, -1], [181, -1], [181, 1], [179, 1], [179, -1]]
    inputs = {
        "boundary": {"type": "Polygon", "coordinates": [box]},
        "size": 0.25,
        "smoothing": {"method": "none"},
    }
    job = server.client.post("/processes/mesh/execution", json={"inputs": inputs}).json()
    assert server.wait(job["jobID"])["status"] == "successful"
    doc = server.client.get(f"/jobs/{job['jobID']}/results").json()
    doc["points"] = [[x - 360 if x > 180 else x, y] for x, y in doc["points"]]
    doc.pop("initial", None)
    doc["crs"] = {"input": "EPSG:4326", "mesh": "EPSG:32660"}

    b = browser
    b.goto(server.url + "/viewer")
    b.wait_for("document.body.dataset.ready === 'true'", timeout=30)
    b.evaluate(
        "(() => { const doc = " + json.dumps(doc) + "; const real = window.fetch;"
        " window.fetch = (url, opts) => String(url).includes('jobs/geo-test/results')"
        " ? Promise.resolve(new Response(JSON.stringify(doc),"
        " {status: 200, headers: {'content-type': 'application/json'}})) : real(url, opts); })()"
    )
    b.evaluate("window.evomesh.openResult('geo-test')")
    b.wait_for("document.body.dataset.rendered === 'geo-test'")
    x0, y0, x1, y1 = b.evaluate("Array.from(window.evomesh.view.mesh.box)")
    assert x1 - x0 == pytest.approx(2.0, rel=1e-6)  # continuous across 180, not 358 wide
    assert y1 - y0 == pytest.approx(2.0, rel=1e-6)

    # The readout gives lon/lat in [-180, 180] under the pointer (here: the middle, lon 180).
    r = b.evaluate("document.getElementById('mesh-canvas').getBoundingClientRect().toJSON()")
    sx, sy = b.evaluate(f"window.evomesh.view.toScreen({(x0 + x1) / 2}, {(y0 + y1) / 2})")
    b.call("Input.dispatchMouseEvent", type="mouseMoved", x=r["x"] + sx, y=r["y"] + sy)
    text = b.wait_for(
        "(t => t.includes('lon') && t)(document.getElementById('readout').textContent)"
    )
    lon, lat = (float(v) for v in re.findall(r"(?:lon|lat) (-?[\d.]+)°", text))
    assert abs(lon) == pytest.approx(180.0, abs=0.05)
    assert lat == pytest.approx(0.0, abs=0.05)
