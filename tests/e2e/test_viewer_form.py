"""The viewer's form in a real browser: the progress bar stays in view while the smoothing
parameters are open, an adjustable colour range, and reopening a job restores its inputs."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.conftest import DATA

from . import test_viewer as viewer_tests
from .browser import Browser, chromium_path
from .server import Server
from .test_viewer import _click, _paste, _rect

pytestmark = pytest.mark.e2e

server = viewer_tests.server


@pytest.fixture
def browser(tmp_path: Path) -> Iterator[Browser]:
    """A laptop-sized window: the sidebar overflows once the smoothing parameters are open."""
    assert chromium_path(), "chromium is not installed: `make test` installs it (APT_PACKAGES)"
    with Browser(tmp_path / "profile", width=1280, height=680, timeout=60) as b:
        yield b
        errors = b.console_errors()
        assert not errors, errors


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
