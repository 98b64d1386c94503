"""The viewer's form in a real browser: the progress bar stays in view while the smoothing
parameters are open, an adjustable colour range, and reopening a job restores its inputs."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from matplotlib import colormaps

from tests.conftest import DATA

from . import test_viewer as viewer_tests
from .browser import Browser
from .server import Server
from .test_viewer import METHOD, _canvas_pixels, _choose, _click, _paste, _q, _rect

pytestmark = pytest.mark.e2e

server = viewer_tests.server
#: A smoothing method other than "none", to change the form with.
METHOD_OTHER = METHOD if METHOD != "none" else "laplacian"


@pytest.fixture
def browser(tmp_path: Path) -> Iterator[Browser]:
    """A laptop-sized window: the sidebar overflows once the smoothing parameters are open."""
    yield from viewer_tests.browser_session(tmp_path, width=1280, height=680)


def _ready(b: Browser, server: Server) -> None:
    b.goto(server.url + "/viewer")
    b.wait_for("document.body.dataset.ready === 'true'", timeout=30)
    _paste(b, "#region-text", (DATA / "cases" / "l_shape.geojson").read_text())
    b.wait_for("document.getElementById('region-status').textContent.includes('7 vertices')")


def test_progress_stays_in_view_with_the_parameters_open(server: Server, browser: Browser) -> None:
    b = browser
    _ready(b, server)
    _click(b, "#advanced summary")
    assert b.evaluate("document.getElementById('advanced').open") is True
    sidebar = _rect(b, ".sidebar")
    assert b.evaluate("(s => s.scrollHeight > s.clientHeight)(document.querySelector('.sidebar'))")
    # Submitting shows the bar before the first await: measure it in the same task.
    shown = json.loads(
        b.evaluate(
            "(() => { document.getElementById('submit').click();"
            " const p = document.getElementById('progress'); const r = p.getBoundingClientRect();"
            " const hit = document.elementFromPoint(r.x + r.width / 2, r.y + r.height / 2);"
            " return JSON.stringify({hidden: p.hidden, top: r.top, bottom: r.bottom,"
            " height: r.height, inside: p.contains(hit), status: document.body.dataset.jobStatus});"
            " })()"
        )
    )
    assert shown["hidden"] is False
    assert shown["status"] == "accepted"
    assert shown["height"] > 0
    assert sidebar["y"] <= shown["top"]
    assert shown["bottom"] <= sidebar["y"] + sidebar["height"]
    assert shown["bottom"] <= b.evaluate("window.innerHeight")
    assert shown["inside"], "the progress bar is covered or clipped"
    b.wait_for("document.body.dataset.rendered", timeout=120)


def _share_of_lowest_colour(rgb: np.ndarray) -> float:
    """Share of the canvas in the colour map's lowest colour (viridis' dark purple)."""
    low = np.round(np.asarray(colormaps["viridis"](0.0)[:3]) * 255)
    return float(np.mean(np.linalg.norm(rgb.reshape(-1, 3) - low, axis=1) <= 12))


def test_colour_range_is_adjustable(server: Server, browser: Browser) -> None:
    b = browser
    _ready(b, server)
    _choose(b, "#method", "none")
    _click(b, "#submit")
    b.wait_for("document.body.dataset.rendered", timeout=120)
    lo, hi = (
        float(b.evaluate(f"document.getElementById('legend-{e}').textContent"))
        for e in ("lo", "hi")
    )
    assert b.evaluate("document.getElementById('range-lo').placeholder") == f"{lo:.2f}"
    assert b.evaluate("document.getElementById('range-lo').value") == ""  # default: the data's
    before = _share_of_lowest_colour(_canvas_pixels(b, "viewer-range-data.png"))

    # Widen the range far above the data (quality <= 1): every triangle takes the lowest colours.
    _paste(b, "#range-hi", "10")
    b.evaluate("document.getElementById('range-hi').dispatchEvent(new Event('change'))")
    b.wait_for("document.getElementById('legend-hi').textContent === '10.00'")
    widened = _share_of_lowest_colour(_canvas_pixels(b, "viewer-range-wide.png"))
    assert widened > before + 0.1, (before, widened)  # the mesh fills ~40% of the canvas
    assert b.evaluate("document.getElementById('legend-lo').textContent") == f"{lo:.2f}"

    # Reset goes back to the data's range.
    _click(b, "#range-reset")
    b.wait_for(f"document.getElementById('legend-hi').textContent === '{hi:.2f}'")
    assert b.evaluate("document.getElementById('range-hi').value") == ""
    assert _share_of_lowest_colour(_canvas_pixels(b, "viewer-range-reset.png")) < before + 0.01


def _form(b: Browser) -> dict[str, object]:
    return dict(
        json.loads(
            b.evaluate(
                "JSON.stringify({region: document.getElementById('region-text').value.trim(),"
                " size: document.getElementById('size').value,"
                " growth: document.getElementById('growth').value,"
                " swap: document.getElementById('swap').checked,"
                " method: document.getElementById('method').value,"
                " seed: document.getElementById('p-seed').value})"
            )
        )
    )


def test_opening_a_job_restores_its_region_and_parameters(server: Server, browser: Browser) -> None:
    b = browser
    _ready(b, server)
    _paste(b, "#size", "0.05")
    _paste(b, "#growth", "1.3")
    _click(b, "#swap")
    _choose(b, "#method", "none")
    sent = _form(b)
    assert sent["swap"] is False
    _click(b, "#submit")
    job_id = b.wait_for("document.body.dataset.rendered", timeout=120)

    # Something else in the form: another region, other parameters.
    _choose(
        b, "#example", b.evaluate("document.querySelector('#example option:nth-child(3)').value")
    )
    _paste(b, "#growth", "1.1")
    _click(b, "#swap")
    _choose(b, "#method", METHOD_OTHER)
    assert _form(b)["region"] != sent["region"]

    # Opening the job from the list puts its region and parameters back.
    item = f"#jobs li[data-job='{job_id}']"
    b.wait_for(f"!!{_q(item)}")
    b.evaluate(f"{_q(item)}.scrollIntoView()")  # the sidebar scrolls at this window size
    _click(b, f"{item} .job-id")
    b.wait_for("document.getElementById('region-status').textContent.includes('7 vertices')")
    b.wait_for(f"document.body.dataset.rendered === '{job_id}'")
    assert _form(b) == sent
    assert "7 vertices" in b.evaluate("document.getElementById('region-status').textContent")

    # A job this browser did not send: the parameters its result holds (no region).
    b.evaluate(
        "Object.keys(localStorage).filter(k => k.startsWith('evomesh.job'))"
        ".forEach(k => localStorage.removeItem(k))"
    )
    b.goto("about:blank")  # a new page: only the hash would differ
    b.goto(server.url + f"/viewer#job={job_id}")
    b.wait_for("document.body.dataset.ready === 'true'", timeout=30)
    used = server.client.get(f"/jobs/{job_id}/results").json()["summary"]["parameters"]
    form = _form(b)
    assert form["swap"] is False
    assert form["method"] == "none"
    assert used["smoothing"]["method"] == "none"
    assert form["region"] == ""
