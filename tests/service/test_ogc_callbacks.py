"""Subscriber callbacks against a real HTTP receiver on loopback (http.server in a thread)."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import anyio
import httpx
import pytest

from service.callbacks import private_host

from .conftest import SQUARE, ClientFactory, assert_problem

pytestmark = pytest.mark.anyio

MESH = {"boundary": SQUARE, "size": 0.25, "smoothing": {"method": "none"}}


class Receiver:
    """Records every POST (path, JSON body); answers 500 to the first ``fail_first`` of a path."""

    def __init__(self, fail_first: dict[str, int]) -> None:
        self.calls: list[tuple[str, dict[str, Any], int]] = []
        self.fail_first = dict(fail_first)
        self.lock = threading.Lock()
        receiver = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:
                body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                with receiver.lock:
                    left = receiver.fail_first.get(self.path, 0)
                    receiver.fail_first[self.path] = max(0, left - 1)
                    status = 500 if left else 204
                    receiver.calls.append((self.path, body, status))
                self.send_response(status)
                self.send_header("Content-Length", "0")
                self.end_headers()

            def log_message(self, *args: Any) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}"
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)

    def answered(self, path: str, status: int) -> list[dict[str, Any]]:
        with self.lock:
            return [body for p, body, s in self.calls if p == path and s == status]

    def statuses(self, path: str) -> list[int]:
        with self.lock:
            return [s for p, _, s in self.calls if p == path]


@pytest.fixture
def receiver() -> Iterator[Receiver]:
    r = Receiver({"/done": 2})
    r.thread.start()
    yield r
    r.server.shutdown()
    r.server.server_close()


async def _until(predicate: Any, timeout: float = 60.0) -> None:
    with anyio.fail_after(timeout):
        while not predicate():
            await anyio.sleep(0.02)


def _subscriber(url: str) -> dict[str, str]:
    return {
        "successUri": f"{url}/done",
        "failedUri": f"{url}/failed",
        "inProgressUri": f"{url}/running",
    }


async def _client(make_client: ClientFactory) -> httpx.AsyncClient:
    return await make_client(callback_private_hosts=True, callback_backoff=0.01)


async def test_success_is_called_back_after_retries(
    make_client: ClientFactory, receiver: Receiver
) -> None:
    client = await _client(make_client)
    body = {"inputs": MESH, "subscriber": _subscriber(receiver.url)}
    r = await client.post("/processes/mesh/execution", json=body)
    assert r.status_code == 201, r.text
    job_id = r.json()["jobID"]
    await _until(lambda: receiver.answered("/done", 204))
    # the receiver failed twice with a 500: the third try was delivered
    assert receiver.statuses("/done") == [500, 500, 204]
    (doc,) = receiver.answered("/done", 204)
    assert (doc["jobID"], doc["status"]) == (job_id, "successful")
    assert any(link["rel"].endswith("/results") for link in doc["links"])
    (running,) = receiver.answered("/running", 204)
    assert (running["jobID"], running["status"]) == (job_id, "running")
    assert receiver.statuses("/failed") == []


async def test_failure_is_called_back(make_client: ClientFactory, receiver: Receiver) -> None:
    client = await _client(make_client)
    body = {"inputs": {}, "subscriber": _subscriber(receiver.url)}
    r = await client.post("/processes/fail/execution", json=body)
    assert r.status_code == 201, r.text
    await _until(lambda: receiver.answered("/failed", 204))
    (doc,) = receiver.answered("/failed", 204)
    assert (doc["jobID"], doc["status"]) == (r.json()["jobID"], "failed")
    assert receiver.statuses("/done") == []


async def test_giving_up_after_the_tries(make_client: ClientFactory) -> None:
    receiver = Receiver({"/done": 100})
    receiver.thread.start()
    try:
        client = await make_client(
            callback_private_hosts=True, callback_backoff=0.01, callback_attempts=3
        )
        body = {"inputs": MESH, "subscriber": {"successUri": f"{receiver.url}/done"}}
        assert (await client.post("/processes/mesh/execution", json=body)).status_code == 201
        notifier = client.app.state.callbacks  # type: ignore[attr-defined]
        await _until(lambda: notifier.dropped == 1)
        assert receiver.statuses("/done") == [500, 500, 500]
    finally:
        receiver.server.shutdown()
        receiver.server.server_close()


async def test_private_hosts_are_refused_by_default(client: httpx.AsyncClient) -> None:
    body = {"inputs": MESH, "subscriber": {"successUri": "http://127.0.0.1:9/done"}}
    r = await client.post("/processes/mesh/execution", json=body)
    assert_problem(r, 400, "invalid-parameter")
    assert (await client.get("/jobs")).json()["numberMatched"] == 0  # nothing was created


@pytest.mark.parametrize(
    "uri", ["ftp://example.org/x", "example.org/done", "http:///x", "file:///etc"]
)
async def test_non_http_uris_are_invalid(client: httpx.AsyncClient, uri: str) -> None:
    body = {"inputs": MESH, "subscriber": {"failedUri": uri}}
    r = await client.post("/processes/mesh/execution", json=body)
    assert_problem(r, 422)


@pytest.mark.parametrize(
    ("uri", "private"),
    [
        ("http://localhost:8000/x", True),
        ("http://10.1.2.3/x", True),
        ("http://[::1]:80/x", True),
        ("http://169.254.169.254/latest", True),
        ("https://example.org/x", False),
        ("http://8.8.8.8/x", False),
    ],
)
def test_private_host(uri: str, private: bool) -> None:
    assert private_host(uri) is private
