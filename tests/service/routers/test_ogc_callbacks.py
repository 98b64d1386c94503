"""Subscriber callbacks against a real HTTP receiver on loopback (http.server in a thread)."""

from __future__ import annotations

import json
import threading
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import anyio
import httpx
import pytest

from service.app import create_app
from service.callbacks import CallbackNotifier, private_host
from service.jobs.sqlite import SqliteJobStore
from service.jobs.store import NewJob

from ..conftest import (
    SQUARE,
    TEST_PROCESSES,
    ClientFactory,
    assert_problem,
    make_settings,
    wait_for,
)

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


def test_the_store_keeps_a_subscriber_state_across_reopening(tmp_path: Path) -> None:
    path = tmp_path / "jobs.sqlite3"
    store = SqliteJobStore(path)
    for job_id in ("a", "b", "c"):
        store.create(NewJob(job_id, "mesh", {}))
    state = {"base": "http://x", "uris": {"successUri": "http://r/done"}, "sent": []}
    assert store.set_subscriber("a", state)
    assert store.set_subscriber("b", {**state, "sent": ["inProgressUri"]})
    assert not store.set_subscriber("nope", state)  # no such job
    store._conn().execute("UPDATE jobs SET subscriber = '{not json' WHERE id = 'c'")
    store.close()
    again = SqliteJobStore(path)
    assert again.subscribed() == [("a", state), ("b", {**state, "sent": ["inProgressUri"]})]
    assert again.set_subscriber("a", None)
    assert [job_id for job_id, _ in again.subscribed()] == ["b"]
    again.close()


@asynccontextmanager
async def _service(data: Path) -> AsyncIterator[httpx.AsyncClient]:
    """A started app on ``data`` (a service process, in this one); stopped on leaving."""
    settings = make_settings(
        data, callback_private_hosts=True, callback_backoff=0.01, callback_attempts=20
    )
    app = create_app(settings, processes=TEST_PROCESSES)
    async with app.router.lifespan_context(app):
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://testserver") as c:
            c.app = app  # type: ignore[attr-defined]
            yield c


def _notifier(client: httpx.AsyncClient) -> CallbackNotifier:
    notifier: CallbackNotifier = client.app.state.callbacks  # type: ignore[attr-defined]
    return notifier


async def test_the_subscriber_is_stored_before_the_answer_and_forgotten_once_done(
    make_client: ClientFactory, receiver: Receiver, tmp_path: Path
) -> None:
    client = await _client(make_client)
    body = {"inputs": {"seconds": 30}, "subscriber": _subscriber(receiver.url)}
    r = await client.post("/processes/sleep/execution", json=body)
    assert r.status_code == 201, r.text
    store = client.app.state.manager.store  # type: ignore[attr-defined]
    ((job_id, state),) = store.subscribed()
    assert job_id == r.json()["jobID"]
    assert state["uris"] == _subscriber(receiver.url)
    assert state["base"] == "http://testserver"
    await _until(lambda: receiver.answered("/running", 204))
    await _until(lambda: store.subscribed() == [] or store.subscribed()[0][1]["sent"])
    assert store.subscribed()[0][1]["sent"] == ["inProgressUri"]
    await client.delete(f"/jobs/{job_id}")  # dismissed: nothing more to call back
    await _until(lambda: store.subscribed() == [])
    assert receiver.statuses("/done") == receiver.statuses("/failed") == []


async def test_a_delivery_cut_by_a_stop_is_resumed_by_the_next_start(tmp_path: Path) -> None:
    receiver = Receiver({"/done": 10**6})  # down until after the restart
    receiver.thread.start()
    data = tmp_path / "data"
    try:
        async with _service(data) as client:
            body = {"inputs": MESH, "subscriber": _subscriber(receiver.url)}
            job_id = (await client.post("/processes/mesh/execution", json=body)).json()["jobID"]
            assert (await wait_for(client, job_id))["status"] == "successful"
            await _until(lambda: 500 in receiver.statuses("/done"))
            await _until(lambda: receiver.answered("/running", 204))
            # ... and kept as sent: the receiver's answer comes before the store records it.
            store = client.app.state.manager.store  # type: ignore[attr-defined]
            await _until(lambda: "inProgressUri" in dict(store.subscribed())[job_id]["sent"])
        with receiver.lock:
            receiver.fail_first["/done"] = 0  # the receiver is back
        async with _service(data) as client:
            notifier = _notifier(client)
            assert notifier.resumed == 1
            await _until(lambda: receiver.answered("/done", 204))
            (doc,) = receiver.answered("/done", 204)
            assert (doc["jobID"], doc["status"]) == (job_id, "successful")
            # the start was delivered before the stop: it is not sent again
            assert receiver.statuses("/running") == [204]
            store = client.app.state.manager.store  # type: ignore[attr-defined]
            await _until(lambda: store.subscribed() == [])
    finally:
        receiver.server.shutdown()
        receiver.server.server_close()
