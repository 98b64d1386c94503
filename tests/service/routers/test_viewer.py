"""The viewer page and its assets: served by the service, HTML for browsers at ``/``, nothing
loaded from elsewhere, and the page's colour map equal to the pictures'."""

from __future__ import annotations

import re

import httpx
import numpy as np
import pytest
from matplotlib import colormaps

from service.routers.viewer import STATIC

pytestmark = pytest.mark.anyio

BROWSER_ACCEPT = "text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8"


async def test_root_is_the_viewer_for_browsers_and_json_for_clients(
    client: httpx.AsyncClient,
) -> None:
    page = await client.get("/", headers={"Accept": BROWSER_ACCEPT})
    assert page.status_code == 200
    assert page.headers["content-type"].startswith("text/html")
    assert "<title>evomesh viewer</title>" in page.text
    assert "default-src 'self'" in page.headers["content-security-policy"]
    for accept in ("*/*", "application/json", "application/json, text/html;q=0.5"):
        r = await client.get("/", headers={"Accept": accept})
        assert r.headers["content-type"] == "application/json", accept
        assert r.headers["vary"] == "Accept"
        links = {link["rel"]: link for link in r.json()["links"]}
        assert links["alternate"]["href"] == "http://testserver/viewer"
        assert links["alternate"]["type"] == "text/html"
    viewer = await client.get("/viewer")
    assert viewer.text == page.text


async def test_every_asset_the_page_names_is_served(client: httpx.AsyncClient) -> None:
    html = (await client.get("/viewer")).text
    names = set(re.findall(r'(?:src|href)="static/([\w.-]+)"', html))
    assert {"app.js", "viewer.css", "favicon.svg"} <= names
    # The scripts are modules importing each other: follow the imports from app.js.
    pending, seen = ["app.js"], set()
    while pending:
        name = pending.pop()
        seen.add(name)
        r = await client.get(f"/static/{name}")
        assert r.status_code == 200, name
        assert r.headers["content-type"].startswith("text/javascript"), r.headers
        pending += [m for m in re.findall(r'from "\./([\w.-]+)"', r.text) if m not in seen]
    for name in names - {"app.js"}:
        assert (await client.get(f"/static/{name}")).status_code == 200, name
    assert seen == {p.name for p in STATIC.glob("*.js")}  # no script is left unused
    assert (await client.get("/static/../app.py")).status_code == 404


def test_the_page_loads_nothing_from_elsewhere() -> None:
    for path in STATIC.rglob("*"):
        if path.suffix not in {".html", ".js", ".css", ".svg"}:
            continue  # images (the README's screenshots) load nothing
        if STATIC / "vendor" in path.parents:
            continue  # /docs' Swagger UI: tests/test_docs.py watches what it loads in a browser
        text = path.read_text(encoding="utf-8")
        # The SVG namespace is a name, not a request.
        urls = set(re.findall(r"(?:https?:)?//[\w.-]+\.\w+[^\s\"')]*", text))
        urls -= {"http://www.w3.org/2000/svg"}
        assert not urls, (path.name, urls)
        assert "@import" not in text
        assert "fonts.googleapis" not in text


def test_the_page_colour_map_is_matplotlibs_viridis() -> None:
    text = (STATIC / "colormap.js").read_text()
    hexes = "".join(re.findall(r'"([0-9a-f]+)"', text.split("const HEX =", 1)[1].split(";")[0]))
    page = np.array([int(hexes[i : i + 2], 16) for i in range(0, len(hexes), 2)]).reshape(-1, 3)
    reference = np.round(colormaps["viridis"](np.linspace(0, 1, 256))[:, :3] * 255)
    assert page.shape == (256, 3)
    assert np.array_equal(page, reference)
