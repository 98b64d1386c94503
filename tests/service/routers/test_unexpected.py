"""An unexpected error is a 500 problem that tells a keep-alive client the connection closes."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from service.app import create_app

from ..conftest import make_settings
from ..live import serving


@pytest.fixture
def base_url(tmp_path: Path) -> Iterator[str]:
    """A real server on loopback whose ``/boom`` fails as no handler expects."""
    app = create_app(make_settings(tmp_path))

    def boom() -> None:
        raise RuntimeError("nothing expected this")

    app.add_api_route("/boom", boom)
    with serving(app, log_level="critical") as url:
        yield url


def test_an_unexpected_error_closes_the_connection_and_the_next_request_works(
    base_url: str,
) -> None:
    with httpx.Client(base_url=base_url) as client:
        for _ in range(5):  # the server drops the connection after each: say so every time
            r = client.get("/boom")
            assert r.status_code == 500
            assert r.headers["content-type"] == "application/problem+json"
            assert r.json()["type"] == "urn:evomesh:problem:internal-error"
            assert r.headers["connection"] == "close"
            assert client.get("/processes").status_code == 200
