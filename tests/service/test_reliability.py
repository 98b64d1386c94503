"""Reliability (issue 13, finding 1): what is stored and handed to a worker is the normalised
input, request bodies are bounded in depth before decoding, and a job that cannot reach a worker
fails with the reason, holds no worker and never stops a restart."""

from __future__ import annotations

import json
import zlib
from pathlib import Path
from typing import Any

import anyio
import httpx
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from service.jobs import store as store_module
from service.jobs.backends.local import LocalBackend
from service.jobs.sqlite import SqliteJobStore
from service.jobs.store import NewJob
from service.jobs.task import OutcomeKind, Task, encode_inputs
from service.middleware import json_depth

from .conftest import SQUARE, ClientFactory, app_of, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

NONE = {"method": "none"}


def nested(depth: int, leaf: Any = 1) -> Any:
    """A value ``depth`` arrays and objects deep (alternating)."""
    value = leaf
    for i in range(depth):
        value = [value] if i % 2 else {"x": value}
    return value


def depth_of(value: Any) -> int:
    """The nesting depth of a decoded JSON value, by recursion (the reference)."""
    if isinstance(value, dict):
        return 1 + max((depth_of(v) for v in value.values()), default=0)
    if isinstance(value, list):
        return 1 + max((depth_of(v) for v in value), default=0)
    return 0


_TRICKY = st.text(alphabet='[]{}"\\ab,:', max_size=12)
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | _TRICKY,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(_TRICKY, inner, max_size=4),
    max_leaves=40,
)


@given(JSON_VALUES)
@settings(max_examples=300, deadline=None)
def test_json_depth_agrees_with_the_decoded_value(value: Any) -> None:
    # Brackets, quotes and backslashes inside strings must not count.
    text = json.dumps(value).encode()
    assert json_depth(text) == depth_of(value)


async def _post(client: httpx.AsyncClient, path: str, body: Any) -> httpx.Response:
    return await client.post(
        path, content=json.dumps(body), headers={"Content-Type": "application/json"}
    )


def _with_member(place: str, member: Any) -> tuple[str, dict[str, Any]]:
    """A mesh request (or a batch) carrying ``member`` at ``place``."""
    feature = {"type": "Feature", "geometry": SQUARE, "properties": {}}
    inputs: dict[str, Any] = {"boundary": feature, "size": 0.5, "smoothing": NONE}
    if place == "foreign":
        feature["extra"] = member
    elif place == "properties":
        feature["properties"] = {"deep": member}
    elif place == "outputs":
        return "/processes/mesh/execution", {"inputs": inputs, "outputs": {"mesh": member}}
    elif place == "batch":
        body = {"type": "FeatureCollection", "features": [feature], "inputs": {"size": 0.5}}
        feature["extra"] = member
        return "/batches", body
    return "/processes/mesh/execution", {"inputs": inputs}


async def test_a_poison_member_is_refused_and_the_worker_stays_free(
    client: httpx.AsyncClient,
) -> None:
    # The attack of the report: a valid polygon with a member nested 600 levels deep.
    path, body = _with_member("foreign", nested(600))
    doc = assert_problem(await _post(client, path, body), 422, "limit-exceeded")
    assert "nested 60" in doc["detail"]
    assert (await client.get("/jobs")).json()["numberMatched"] == 0
    job = await submit(client, "mesh", {"boundary": SQUARE, "size": 0.5, "smoothing": NONE})
    assert (await wait_for(client, job["jobID"]))["status"] == "successful"
    assert (await client.get("/ready")).status_code == 200


@given(
    depth=st.integers(min_value=1, max_value=120),
    place=st.sampled_from(["foreign", "properties", "outputs", "batch"]),
)
@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
async def test_any_depth_anywhere_is_a_problem_or_a_job_never_a_500(
    client: httpx.AsyncClient, depth: int, place: str
) -> None:
    path, body = _with_member(place, nested(depth))
    r = await _post(client, path, body)
    total = depth_of(body)
    if total > 32:  # the default max_json_depth
        assert_problem(r, 422, "limit-exceeded")
    else:
        assert r.status_code == 201, r.text


async def test_the_stored_input_is_the_normalised_region_not_the_request(
    client: httpx.AsyncClient,
) -> None:
    feature = {
        "type": "Feature",
        "geometry": {
            "type": "Polygon",
            "coordinates": [[[0, 0, 9], [1, 0, 9], [1, 1, 9], [0, 1, 9]]],
        },
        "properties": {"h": 0.5, "note": {"a": [1, 2, {"b": "c"}]}},
        "foreign": {"anything": [[[["x"]]]]},
    }
    job = await submit(client, "mesh", {"boundary": feature, "smoothing": NONE})
    store = app_of(client).state.manager.store
    stored = store.inputs(job["jobID"])
    assert set(stored) == {
        "parts", "crs", "size", "growth", "size_min", "size_max", "swap", "smoothing",
        "max_triangles", "tagging", "refinements", "constraints", "subdomains", "resample",
        "resample_tolerance",
    }  # fmt: skip
    assert stored["crs"] is None  # planar: no CRS to map back
    # The tagging is plain data (names and runs), never the Feature's other members.
    assert stored["tagging"] == {"names": [None], "features": []}
    assert stored["parts"] == [[[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], []]]
    assert stored["size"] == 0.5
    assert (await wait_for(client, job["jobID"]))["status"] == "successful"


async def test_a_mesh_document_keeps_no_foreign_members(client: httpx.AsyncClient) -> None:
    mesh = {
        "points": [[0, 0], [1, 0], [0, 1]],
        "triangles": [[0, 1, 2]],
        "summary": {"deep": nested(20)},
    }
    job = await submit(client, "quality", {"mesh": mesh})
    stored = app_of(client).state.manager.store.inputs(job["jobID"])
    assert set(stored["mesh"]) == {"points", "triangles"}


async def test_an_idempotency_key_with_a_deep_body_is_a_problem_not_a_500(
    client: httpx.AsyncClient,
) -> None:
    deep = '{"x": ' * 2000 + "1" + "}" * 2000  # json.dumps itself would recurse too deep
    feature = '{"type": "Feature", "geometry": ' + json.dumps(SQUARE) + ', "extra": ' + deep + "}"
    body = '{"inputs": {"boundary": ' + feature + ', "size": 0.5}}'
    r = await client.post(
        "/processes/mesh/execution",
        content=body,
        headers={"Content-Type": "application/json", "Idempotency-Key": "deep"},
    )
    assert_problem(r, 422, "limit-exceeded")


async def test_a_task_that_cannot_be_handed_over_fails_and_frees_the_worker() -> None:
    finished: dict[str, Any] = {}

    class Sink:
        def started(self, job_id: str) -> None: ...

        def progress(self, job_id: str, percent: int, message: str) -> None: ...

        def finished(self, job_id: str, outcome: Any) -> None:
            finished[job_id] = outcome

    backend = LocalBackend(workers=1, warmup=False)
    await backend.start(Sink())
    try:
        # A payload pickle cannot take (a lambda): the hand-over fails, not the worker.
        backend.submit(Task("bad", "tests.service.tasks:echo", {"f": lambda: 0}))
        backend.submit(Task("good", "tests.service.tasks:echo", {"n": 1}))
        with anyio.fail_after(30):
            while len(finished) < 2:
                await anyio.sleep(0.02)
        assert finished["bad"].kind is OutcomeKind.error
        assert "could not be handed to a worker" in finished["bad"].reason
        assert finished["good"].kind is OutcomeKind.succeeded
        assert backend.stats().busy == 0
    finally:
        await backend.close()


async def test_a_failed_hand_over_fails_the_job_with_the_reason(client: httpx.AsyncClient) -> None:
    manager = app_of(client).state.manager
    real = manager.backend.submit

    def broken(task: Task) -> None:
        raise RecursionError("maximum recursion depth exceeded while pickling an object")

    manager.backend.submit = broken
    try:
        job = await submit(client, "sleep", {"seconds": 0})
    finally:
        manager.backend.submit = real
    done = await wait_for(client, job["jobID"])
    assert done["status"] == "failed"
    assert "could not be handed to a worker: RecursionError" in done["message"]
    assert manager.waiting == 0
    follow = await submit(client, "sleep", {"seconds": 0})
    assert (await wait_for(client, follow["jobID"]))["status"] == "successful"


async def test_a_job_whose_input_cannot_be_read_is_failed_at_restart(
    make_client: ClientFactory, tmp_path: Path
) -> None:
    data = tmp_path / "poisoned"
    store = SqliteJobStore(data / "jobs.sqlite3")
    store.create(NewJob("poisoned", "sleep", {"seconds": 0}))
    store.create(NewJob("fine", "sleep", {"seconds": 0}))
    conn = store._conn()
    conn.execute("UPDATE jobs SET inputs = ? WHERE id = 'poisoned'", (b"not zlib",))
    conn.execute(
        "UPDATE jobs SET inputs = ? WHERE id = 'fine'",
        (zlib.compress(json.dumps({"seconds": 0}).encode()),),
    )
    store.close()
    client = await make_client(data_dir=data)  # starts: one bad row is never fatal
    bad = await wait_for(client, "poisoned")
    assert bad["status"] == "failed"
    assert "stored input" in bad["message"]
    assert (await wait_for(client, "fine"))["status"] == "successful"


async def test_recovery_hands_the_stored_bytes_to_the_worker(
    make_client: ClientFactory, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """At a restart the API process neither decodes nor encodes a stored input: the worker gets
    the stored bytes, as on the first run. A row that is not a zlib stream is failed there
    (StoreCorrupt), one broken further in by its worker; neither stops the start."""
    data = tmp_path / "recovered"
    store = SqliteJobStore(data / "jobs.sqlite3")
    for job_id in ("fine", "truncated", "text"):
        store.create(NewJob(job_id, "sleep", {"seconds": 0}))
    conn = store._conn()
    stored = encode_inputs({"seconds": 0})
    conn.execute("UPDATE jobs SET inputs = ? WHERE id = 'truncated'", (stored[:-6],))
    conn.execute("UPDATE jobs SET inputs = ? WHERE id = 'text'", ('{"seconds": 0}',))
    store.close()

    def no_decoding(data: bytes) -> Any:
        raise AssertionError("stored inputs decoded in the API process")

    monkeypatch.setattr(store_module, "decode_inputs", no_decoding)
    handed: list[tuple[str, type]] = []
    submit = LocalBackend.submit

    def hand(self: LocalBackend, task: Task) -> None:
        handed.append((task.job_id, type(task.payload)))
        submit(self, task)

    monkeypatch.setattr(LocalBackend, "submit", hand)
    client = await make_client(data_dir=data, backend="local")
    assert (await wait_for(client, "fine"))["status"] == "successful"
    for job_id, why in (("truncated", "incomplete or truncated"), ("text", "not bytes")):
        doc = await wait_for(client, job_id)
        assert doc["status"] == "failed", doc
        assert "stored input" in doc["message"], doc
        assert why in doc["message"], doc
    assert sorted(handed) == [("fine", bytes), ("truncated", bytes)]


async def test_a_restart_after_poison_requests_is_clean(
    make_client: ClientFactory, tmp_path: Path
) -> None:
    data = tmp_path / "restart"
    first = await make_client(data_dir=data)
    for place in ("foreign", "properties", "outputs", "batch"):
        path, body = _with_member(place, nested(600))
        assert_problem(await _post(first, path, body), 422, "limit-exceeded")
    queued = await submit(first, "sleep", {"seconds": 30})
    await wait_for(first, queued["jobID"], {"running"})
    app = app_of(first)
    await app.state.manager.close()  # stopped with a job in flight, as a killed service is
    app.state.manager = None
    second = await make_client(data_dir=data)  # starts, and finds only what it can run
    assert (await second.get("/ready")).status_code == 200
    resumed = await wait_for(second, queued["jobID"], {"running"})
    assert resumed["attempts"] == 1
    await second.delete(f"/jobs/{queued['jobID']}")
    listed = (await second.get("/jobs")).json()
    assert listed["numberMatched"] == 1
