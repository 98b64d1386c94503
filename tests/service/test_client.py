"""The Python client against a scripted service (httpx.MockTransport): what it sends, and how
it reads statuses and problems. The real server is in tests/e2e/test_client.py."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from typing import Any

import httpx
import pytest

from service.client import Client, JobFailed, ProblemError, Status

Handler = Callable[[httpx.Request], httpx.Response]


def _status(job_id: str, status: str, progress: int, message: str = "") -> dict[str, Any]:
    return {"jobID": job_id, "status": status, "progress": progress, "message": message}


def _client(handler: Handler, **kwargs: Any) -> Client:
    return Client("http://svc", transport=httpx.MockTransport(handler), poll=0, **kwargs)


def test_a_failed_job_raises_job_failed_after_reporting_each_status() -> None:
    script: Iterator[dict[str, Any]] = iter(
        [
            _status("j1", "accepted", 0),
            _status("j1", "running", 30, "mesh"),
            _status("j1", "running", 30, "mesh"),  # no change: not reported again
            _status("j1", "failed", 30, "the mesh needs more than 2000000 triangles"),
        ]
    )

    def handler(request: httpx.Request) -> httpx.Response:
        assert request.url.path == "/jobs/j1"
        return httpx.Response(200, json=next(script))

    seen: list[Status] = []
    with _client(handler) as client, pytest.raises(JobFailed) as exc:
        client.job("j1").wait(progress=seen.append)
    assert [s.status for s in seen] == ["accepted", "running", "failed"]
    assert str(exc.value) == "job j1 failed: the mesh needs more than 2000000 triangles"
    assert exc.value.status.progress == 30


def test_a_problem_without_json_still_has_status_and_title() -> None:
    def handler(request: httpx.Request) -> httpx.Response:
        return httpx.Response(502, text="<html>proxy error</html>")

    with _client(handler) as client, pytest.raises(ProblemError) as exc:
        client.job("j").status()
    assert (exc.value.status, exc.value.title) == (502, "Bad Gateway")
    assert exc.value.line == "Bad Gateway: <html>proxy error</html>"


def test_requests_carry_the_key_and_only_the_inputs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("EVOMESH_API_KEY", "from-env")
    sent: list[httpx.Request] = []

    def handler(request: httpx.Request) -> httpx.Response:
        sent.append(request)
        if request.url.path == "/batches":
            return httpx.Response(201, json={"batchID": "b", "jobs": [{"jobID": "x"}]})
        return httpx.Response(201, json=_status("x", "accepted", 0))

    region = {"outer": [[0, 0], [1, 0], [0, 1]]}
    doc = {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 1, 2]], "summary": {}}
    with _client(handler) as client:
        assert client.mesh(region, size=0.5, swap=False).id == "x"
        client.smooth(doc, smoothing={"method": "none"})
        batch = client.batch([region], size=0.2)
    assert [r.headers["X-API-Key"] for r in sent] == ["from-env"] * 3
    bodies = [json.loads(r.content) for r in sent]
    assert bodies[0] == {"inputs": {"boundary": region, "size": 0.5, "swap": False}}
    assert bodies[1]["inputs"]["mesh"] == {k: doc[k] for k in ("points", "triangles")}
    assert bodies[2] == {
        "process": "mesh",
        "inputs": {"size": 0.2},
        "requests": [{"inputs": {"boundary": region}}],
    }
    assert [j.id for j in batch.jobs] == ["x"]


def test_a_shapely_like_region_is_sent_as_geojson() -> None:
    class Square:
        @property
        def __geo_interface__(self) -> dict[str, Any]:
            return {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 0]]]}

    sent: list[dict[str, Any]] = []

    def handler(request: httpx.Request) -> httpx.Response:
        sent.append(json.loads(request.content))
        return httpx.Response(201, json=_status("x", "accepted", 0))

    with _client(handler, api_key="k") as client:
        client.mesh(Square(), size=0.1)
    assert sent[0]["inputs"]["boundary"] == Square().__geo_interface__
