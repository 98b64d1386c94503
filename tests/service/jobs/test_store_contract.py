"""The JobStore contract: every implementation passes these tests."""

from __future__ import annotations

import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from service.jobs.memory import MemoryJobStore, MemoryTables
from service.jobs.sqlite import SqliteJobStore
from service.jobs.store import IdempotencyConflict, JobStatus, JobStore, NewJob, StoreError
from service.jobs.task import encode_inputs


class Clock:
    def __init__(self) -> None:
        self.now = 1_000.0

    def __call__(self) -> float:
        self.now += 1.0
        return self.now


Opener = Callable[[], JobStore]


def _sqlite(tmp_path: Path, clock: Clock) -> Opener:
    return lambda: SqliteJobStore(tmp_path / "jobs.sqlite3", clock=clock)


def _memory(tmp_path: Path, clock: Clock) -> Opener:
    tables = MemoryTables()  # what a reopened store finds, as the file is for SQLite
    return lambda: MemoryJobStore(clock=clock, tables=tables)


#: Implementations: name -> (tmp_path, clock) -> opener of a store on the same storage.
IMPLEMENTATIONS = {"sqlite": _sqlite, "memory": _memory}


@pytest.fixture(params=sorted(IMPLEMENTATIONS))
def opener(request: pytest.FixtureRequest, tmp_path: Path, clock: Clock) -> Opener:
    factory: Callable[[Path, Clock], Opener] = IMPLEMENTATIONS[request.param]
    return factory(tmp_path, clock)


@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
def store(opener: Opener) -> Iterator[JobStore]:
    s = opener()
    yield s
    s.close()


def job(i: int = 1, process: str = "mesh", **kw: object) -> NewJob:
    return NewJob(f"job-{i}", process, {"size": 0.1 * i, "nested": {"a": [1, 2]}}, seed=i, **kw)  # type: ignore[arg-type]


def test_create_then_get_and_inputs(store: JobStore) -> None:
    record, created = store.create(job(1))
    assert created
    assert record.status is JobStatus.accepted
    got = store.get("job-1")
    assert got is not None
    assert (got.id, got.process, got.status, got.seed, got.attempts) == (
        "job-1", "mesh", JobStatus.accepted, 1, 0,
    )  # fmt: skip
    assert store.inputs("job-1") == {"size": 0.1, "nested": {"a": [1, 2]}}
    assert store.get("nope") is None
    assert store.inputs("nope") is None


def test_idempotency_key_returns_the_same_job_or_conflicts(store: JobStore) -> None:
    first, created = store.create(job(1, idempotency_key="k", request_hash="h1"))
    assert created
    again, created = store.create(job(2, idempotency_key="k", request_hash="h1"))
    assert not created
    assert again.id == first.id
    assert store.get("job-2") is None
    with pytest.raises(IdempotencyConflict) as exc:
        store.create(job(3, idempotency_key="k", request_hash="h2"))
    assert exc.value.job_id == "job-1"


def test_status_flow_to_successful_keeps_the_result(store: JobStore) -> None:
    store.create(job(1))
    assert not store.set_progress("job-1", 10, "mesh")  # not running yet
    assert not store.finish("job-1", b"x", {})
    assert store.mark_running("job-1", 1)
    assert not store.mark_running("job-1", 2)  # only from accepted
    assert store.set_progress("job-1", 150, "smooth")
    running = store.get("job-1")
    assert running is not None
    assert (running.status, running.progress, running.message) == (JobStatus.running, 100, "smooth")
    assert running.started is not None
    assert store.finish("job-1", b"\x00result", {"triangles": 7})
    done = store.get("job-1")
    assert done is not None
    assert done.status is JobStatus.successful
    assert done.meta == {"triangles": 7}
    assert done.finished is not None
    assert store.result("job-1") == b"\x00result"
    assert not store.fail("job-1", "late")  # final stays final
    assert not store.requeue("job-1", "late")


def test_fail_and_requeue(store: JobStore) -> None:
    store.create(job(1))
    store.mark_running("job-1", 1)
    assert store.requeue("job-1", "retrying")
    r = store.get("job-1")
    assert r is not None
    assert (r.status, r.attempts, r.started) == (JobStatus.accepted, 1, None)
    store.mark_running("job-1", 2)
    assert store.requeue("job-1", "service stopped", keep_attempt=False)
    r = store.get("job-1")
    assert r is not None
    assert r.attempts == 1
    assert r.failure == ""
    assert store.fail("job-1", "worker died", "job-crashed")
    r = store.get("job-1")
    assert r is not None
    assert (r.status, r.message, r.failure) == (JobStatus.failed, "worker died", "job-crashed")
    assert store.result("job-1") is None


def test_dismiss_any_status_drops_the_result(store: JobStore) -> None:
    store.create(job(1))
    store.create(job(2))
    store.mark_running("job-2", 1)
    store.finish("job-2", b"r", {})
    for job_id in ("job-1", "job-2"):
        r = store.dismiss(job_id)
        assert r is not None
        assert r.status is JobStatus.dismissed
    assert store.result("job-2") is None
    assert not store.mark_running("job-1", 1)  # a dismissed job never runs
    assert store.dismiss("nope") is None


def test_search_filters_and_pages_newest_first(store: JobStore) -> None:
    for i in range(1, 8):
        store.create(job(i, process="mesh" if i % 2 else "smooth"))
    store.mark_running("job-1", 1)
    page, total = store.search(limit=3)
    assert total == 7
    assert [r.id for r in page] == ["job-7", "job-6", "job-5"]
    page, total = store.search(limit=3, offset=6)
    assert [r.id for r in page] == ["job-1"]
    page, total = store.search(process=["smooth"])
    assert total == 3
    assert {r.process for r in page} == {"smooth"}
    page, total = store.search(status=[JobStatus.running])
    assert [r.id for r in page] == ["job-1"]
    page, total = store.search(status=[JobStatus.running, JobStatus.accepted], process=["mesh"])
    assert total == 4


def test_records_unfinished_and_counts(store: JobStore) -> None:
    for i in range(1, 5):
        store.create(job(i))
    store.mark_running("job-2", 1)
    store.mark_running("job-3", 1)
    store.finish("job-3", b"", {})
    store.fail("job-4", "x")
    assert [r.id for r in store.records(["job-3", "nope", "job-1"])] == ["job-3", "job-1"]
    assert [r.id for r in store.unfinished()] == ["job-1", "job-2"]
    counts = store.counts()
    assert counts == {
        JobStatus.accepted: 1,
        JobStatus.running: 1,
        JobStatus.successful: 1,
        JobStatus.failed: 1,
        JobStatus.dismissed: 0,
    }


def test_batch_is_created_whole_or_not_at_all(store: JobStore) -> None:
    batch = store.create_batch("b1", "mesh", [job(1, batch_id="b1"), job(2, batch_id="b1")])
    assert batch.job_ids == ("job-1", "job-2")
    got = store.batch("b1")
    assert got is not None
    assert got.job_ids == ("job-1", "job-2")
    assert got.process == "mesh"
    r = store.get("job-2")
    assert r is not None
    assert r.batch_id == "b1"
    with pytest.raises(Exception):  # noqa: B017, PT011 - each store raises its own error
        store.create_batch("b2", "mesh", [job(3, batch_id="b2"), job(1, batch_id="b2")])
    assert store.get("job-3") is None
    assert store.batch("b2") is None
    assert store.batch("nope") is None


def test_purge_removes_only_old_final_jobs(store: JobStore, clock: Clock) -> None:
    for i in range(1, 5):
        store.create(job(i))
    store.mark_running("job-1", 1)
    store.finish("job-1", b"r", {})
    store.fail("job-2", "x")
    cutoff = clock.now + 0.5
    store.dismiss("job-3")  # finished after the cutoff
    assert store.purge(cutoff) == 2
    assert store.get("job-1") is None
    assert store.result("job-1") is None
    assert store.get("job-2") is None
    assert store.get("job-3") is not None
    assert store.get("job-4") is not None  # unfinished: never purged


def test_state_survives_reopening(opener: Opener) -> None:
    first = opener()
    first.create(job(1))
    first.mark_running("job-1", 1)
    first.close()
    second = opener()
    try:
        r = second.get("job-1")
        assert r is not None
        assert r.status is JobStatus.running
        assert [u.id for u in second.unfinished()] == ["job-1"]
        second.ping()
    finally:
        second.close()


def test_concurrent_writers_lose_nothing(store: JobStore) -> None:
    errors: list[BaseException] = []

    def writer(t: int) -> None:
        try:
            for i in range(40):
                store.create(NewJob(f"t{t}-{i}", "mesh", {"i": i}))
                store.mark_running(f"t{t}-{i}", 1)
                store.set_progress(f"t{t}-{i}", 50, "mesh")
        except BaseException as exc:  # collected and re-raised on the test thread
            errors.append(exc)

    threads = [threading.Thread(target=writer, args=(t,)) for t in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert store.counts()[JobStatus.running] == 160


def test_inputs_keep_any_json_value(store: JobStore) -> None:
    inputs = {"big": 10**30, "text": "é\u2028", "nested": [None, True, 1.5, {"k": []}]}
    store.create(NewJob("j", "mesh", inputs))
    assert store.inputs("j") == inputs


def _stored_inputs(store: JobStore, job_id: str) -> bytes:
    """The inputs of a job as the store keeps them."""
    if isinstance(store, SqliteJobStore):
        row = store._conn().execute("SELECT inputs FROM jobs WHERE id = ?", (job_id,)).fetchone()
        return bytes(row[0])
    assert isinstance(store, MemoryJobStore)
    return store.tables.jobs[job_id].inputs


def test_inputs_given_encoded_are_kept_as_the_store_would_encode_them(store: JobStore) -> None:
    inputs = {"big": 10**30, "mesh": {"points": [[0.5, 1.25]] * 50, "triangles": [[0, 1, 2]]}}
    store.create(NewJob("plain", "mesh", inputs))
    store.create_batch("b", "mesh", [NewJob("encoded", "mesh", encode_inputs(inputs))])
    assert store.inputs("encoded") == store.inputs("plain") == inputs
    assert _stored_inputs(store, "encoded") == _stored_inputs(store, "plain")
    assert _stored_inputs(store, "plain") == encode_inputs(inputs)


def test_stored_inputs_are_the_stored_bytes_as_they_are(store: JobStore) -> None:
    inputs = {"big": 10**30, "mesh": {"points": [[0.5, 1.25]] * 50}}
    store.create(NewJob("j", "mesh", inputs))
    assert store.stored_inputs("j") == _stored_inputs(store, "j") == encode_inputs(inputs)
    assert store.stored_inputs("nope") is None


def test_an_older_sqlite_file_gains_the_failure_kind(tmp_path: Path) -> None:
    path = tmp_path / "jobs.sqlite3"
    old = SqliteJobStore(path)
    old.create(job(1))
    old.fail("job-1", "stopped after exceeding the time limit of 2 s")
    old._conn().execute("ALTER TABLE jobs DROP COLUMN failure")  # as a file before kinds
    old.close()
    store = SqliteJobStore(path)
    try:
        before = store.get("job-1")
        assert before is not None
        assert (before.status, before.failure) == (JobStatus.failed, "")
        store.create(job(2))
        assert store.fail("job-2", "the region is empty", "invalid-input")
        after = store.get("job-2")
        assert after is not None
        assert after.failure == "invalid-input"
    finally:
        store.close()


# -- every store behaves as the SQLite store, the reference --------------------------------------
_IDS = st.sampled_from(["a", "b", "c", "d"])
_OPERATIONS = st.one_of(
    st.tuples(
        st.just("create"),
        _IDS,
        st.sampled_from(["mesh", "smooth"]),
        st.sampled_from(["", "alice", "bob"]),
        st.none() | st.sampled_from(["k1", "k2"]),
        st.sampled_from(["h1", "h2"]),
        st.booleans(),
    ),
    st.tuples(st.just("create_batch"), st.sampled_from(["b1", "b2"]), st.lists(_IDS, max_size=3)),
    st.tuples(st.just("mark_running"), _IDS, st.integers(1, 3)),
    st.tuples(st.just("set_progress"), _IDS, st.integers(-10, 120), st.sampled_from(["mesh", "x"])),
    st.tuples(st.just("finish"), _IDS, st.binary(max_size=4), st.sampled_from([{}, {"n": [1, 2]}])),
    st.tuples(st.just("fail"), _IDS, st.just("broken"), st.sampled_from(["", "job-crashed"])),
    st.tuples(st.just("requeue"), _IDS, st.booleans()),
    st.tuples(st.just("dismiss"), _IDS),
    st.tuples(st.just("purge"), st.integers(0, 40)),
)


def _apply(store: JobStore, op: tuple[Any, ...]) -> object:
    """Run one operation; an error is its kind (each store raises its own for a repeated id)."""
    name, *args = op
    try:
        if name == "create":
            job_id, process, owner, key, digest, encoded = args
            inputs = encode_inputs({"id": job_id}) if encoded else {"id": job_id}
            new = NewJob(job_id, process, inputs, 1, None, key, digest, owner)
            return store.create(new)
        if name == "create_batch":
            batch_id, ids = args
            jobs = [NewJob(f"{batch_id}-{i}", "mesh", {}, batch_id=batch_id) for i in ids]
            return store.create_batch(batch_id, "mesh", jobs, "alice")
        if name == "finish":
            return store.finish(args[0], args[1], args[2])
        if name == "requeue":
            return store.requeue(args[0], "again", keep_attempt=args[1])
        if name == "purge":
            return store.purge(1_000.0 + args[0])
        result: object = getattr(store, name)(*args)
        return result
    except IdempotencyConflict as exc:
        return ("conflict", exc.job_id)
    except StoreError:
        return "error"


def _state(store: JobStore) -> object:
    everyone = store.search(limit=100)
    ids = [r.id for r in everyone[0]]
    return (
        everyone,
        store.search(owner="alice", status=[JobStatus.accepted, JobStatus.running], limit=2),
        store.search(process=["smooth"], offset=1),
        store.unfinished(),
        store.counts(),
        store.records([*reversed(ids), "nope"]),
        {i: (store.inputs(i), store.result(i)) for i in ids},
        {b: store.batch(b) for b in ("b1", "b2")},
    )


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(_OPERATIONS, max_size=25))
def test_memory_store_behaves_as_the_sqlite_store(operations: list[tuple[Any, ...]]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        reference = SqliteJobStore(Path(tmp) / "jobs.sqlite3", clock=Clock())
        memory = MemoryJobStore(clock=Clock())
        try:
            for op in operations:
                assert _apply(memory, op) == _apply(reference, op), op
            assert _state(memory) == _state(reference)
        finally:
            reference.close()
            memory.close()
