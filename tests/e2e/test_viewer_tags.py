"""The viewer colours a tagged result by region and draws its tagged lines with a legend, in a
real browser against a real server (the document is served to the page in place of a job's,
as the request path does not tag meshes yet)."""

from __future__ import annotations

import json

import pytest

from ..service.formats.test_tagged_formats import DOC
from . import test_viewer as viewer_tests
from .browser import Browser
from .server import Server

pytestmark = pytest.mark.e2e

server = viewer_tests.server
browser = viewer_tests.browser


def test_regions_and_tagged_lines_are_shown(server: Server, browser: Browser) -> None:
    b = browser
    b.goto(server.url + "/viewer")
    b.wait_for("document.body.dataset.ready === 'true'", timeout=30)
    b.evaluate(
        "(() => { const doc = " + json.dumps(DOC) + "; const real = window.fetch;"
        " window.fetch = (url, opts) => String(url).includes('jobs/tags-test/results')"
        " ? Promise.resolve(new Response(JSON.stringify(doc),"
        " {status: 200, headers: {'content-type': 'application/json'}})) : real(url, opts); })()"
    )
    b.evaluate("window.evomesh.openResult('tags-test')")
    b.wait_for("document.body.dataset.rendered === 'tags-test'")
    assert b.evaluate("document.querySelector('[data-color=region]').hidden") is False
    tags = b.evaluate("[...document.querySelectorAll('#legend-tags span')].map(s => s.textContent)")
    assert tags == ["steel/outer", "water/outer", "water/hole-1", "inlet"]
    b.evaluate("document.querySelector('[data-color=region]').click()")
    b.wait_for("document.getElementById('legend-title').textContent === 'region: steel, water'")
    assert b.evaluate("window.evomesh.view.mesh.lines.length") == 2 * len(DOC["lines"])
    assert b.console_errors() == []
