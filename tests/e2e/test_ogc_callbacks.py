"""Subscriber callbacks survive a killed service: a real ``evomesh serve`` is killed (SIGKILL,
no shutdown) after its job ended but before the receiver, down meanwhile, took the callback; the
next server on the same data folder delivers it."""

from __future__ import annotations

import contextlib
import os
import signal
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.service.routers.test_ogc_callbacks import Receiver

from .server import Server, descendants

pytestmark = pytest.mark.e2e

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
MESH = {"boundary": SQUARE, "size": 0.25, "smoothing": {"method": "none"}}
#: Callbacks to loopback allowed; tries enough to outlast the kill, spaced 0.1 s and more.
ENV = {
    "EVOMESH_CALLBACK_PRIVATE_HOSTS": "true",
    "EVOMESH_CALLBACK_BACKOFF": "0.1",
    "EVOMESH_CALLBACK_ATTEMPTS": "20",
}


@pytest.fixture
def receiver() -> Iterator[Receiver]:
    r = Receiver({"/done": 10**6})  # down (500) until the test says
    r.thread.start()
    yield r
    r.server.shutdown()
    r.server.server_close()


def _until(predicate: Callable[[], object], timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline
        time.sleep(0.05)


def _kill(server: Server) -> None:
    """SIGKILL the server and its workers: nothing gets to run a shutdown."""
    for pid in [*descendants(server.proc.pid), server.proc.pid]:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
    server.stop()


def test_a_callback_not_delivered_before_a_kill_is_delivered_after_restart(
    tmp_path: Path, receiver: Receiver
) -> None:
    data = tmp_path / "data"
    first = Server(data, workers=1, **ENV)
    try:
        subscriber = {
            "successUri": f"{receiver.url}/done",
            "inProgressUri": f"{receiver.url}/running",
        }
        body = {"inputs": MESH, "subscriber": subscriber}
        r = first.client.post("/processes/mesh/execution", json=body)
        assert r.status_code == 201, r.text
        job_id = r.json()["jobID"]
        assert first.wait(job_id)["status"] == "successful"
        _until(lambda: receiver.answered("/running", 204))
        _until(lambda: 500 in receiver.statuses("/done"))  # tried, and refused
    finally:
        _kill(first)
    assert first.proc.returncode == -signal.SIGKILL
    with receiver.lock:
        receiver.fail_first["/done"] = 0  # the receiver is back
    second = Server(data, workers=1, **ENV)
    try:
        _until(lambda: receiver.answered("/done", 204))
        (doc,) = receiver.answered("/done", 204)
        assert (doc["jobID"], doc["status"]) == (job_id, "successful")
        assert any(link["rel"].endswith("/results") for link in doc["links"])
        assert receiver.statuses("/running") == [204]  # delivered before the kill: not resent
        assert "callbacks resumed" in second.log_path.read_text()
    finally:
        second.stop()
