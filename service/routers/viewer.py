"""The web viewer: one HTML page and its scripts, all served by the service (no CDN, no fonts
from elsewhere), so the page works on a machine without internet.

The page is at ``/viewer``, and at ``/`` for clients that ask for HTML (browsers); JSON clients
keep getting the OGC landing document there.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

from fastapi import APIRouter, FastAPI
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles

from ..negotiate import ranked

__all__ = ["STATIC", "install", "page", "prefers_html"]

#: The page's assets (package data).
STATIC = Path(__file__).resolve().parent.parent / "static"

#: Everything the page loads comes from this service; blob: for downloads made by scripts.
_CSP = (
    "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
    "style-src 'self'; script-src 'self'; object-src 'none'; base-uri 'self'; "
    "frame-ancestors 'self'"
)

router = APIRouter(include_in_schema=False)


@cache
def _html() -> str:
    return (STATIC / "viewer.html").read_text(encoding="utf-8")


def page() -> HTMLResponse:
    """The viewer page."""
    return HTMLResponse(
        _html(),
        headers={
            "Cache-Control": "no-cache",
            "Content-Security-Policy": _CSP,
            "X-Content-Type-Options": "nosniff",
            "Vary": "Accept",
        },
    )


@router.get("/viewer", response_class=HTMLResponse)
def viewer() -> HTMLResponse:
    return page()


def prefers_html(accept: str) -> bool:
    """Whether an ``Accept`` header ranks HTML above JSON: browsers do; curl, httpx and OGC
    clients (``*/*`` or ``application/json``) do not.

    >>> prefers_html("text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8")
    True
    >>> prefers_html("*/*"), prefers_html("application/json"), prefers_html("")
    (False, False, False)
    >>> prefers_html("application/json, text/html;q=0.5")
    False
    """
    weights = ranked(accept)
    html = max((q for media, q in weights if media == "text/html"), default=0.0)
    json = max((q for media, q in weights if media == "application/json"), default=0.0)
    if html <= 0.0 or html < json:
        return False
    if html > json:
        return True
    medias = [media for media, _ in weights]
    return medias.index("text/html") < medias.index("application/json")


def install(app: FastAPI) -> None:
    """Serve the viewer page and its assets from ``app``."""
    app.include_router(router)
    app.mount("/static", StaticFiles(directory=STATIC), name="static")
