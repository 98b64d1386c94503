"""Store failures (issue 13, finding 3): a write that fails is a 503 with Retry-After or a write
kept for the reconciler, never a lost or stranded job; one bad row is failed, never fatal."""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import anyio
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from service.jobs.sqlite import SqliteJobStore
from service.jobs.store import StoreCorrupt, StoreUnavailable

from ..conftest import SQUARE, ClientFactory, app_of, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

WRITES = frozenset(
    {"create", "create_batch", "mark_running", "set_progress", "finish", "fail", "requeue"}
)


class FlakyStore:
    """A store whose writes fail (StoreUnavailable, nothing written) while ``failing(name)``."""

    def __init__(self, inner: SqliteJobStore, failing: Callable[[str], bool]) -> None:
        self.inner = inner
        self.failing = failing
        self.failed: list[str] = []

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self.inner, name)
        if name not in WRITES:
            return attr

        def call(*args: Any, **kwargs: Any) -> Any:
            if self.failing(name):
                self.failed.append(name)
                raise StoreUnavailable(f"injected failure of {name}")
            return attr(*args, **kwargs)

        return call


@pytest.fixture
def inner(tmp_path: Path) -> Iterator[SqliteJobStore]:
    store = SqliteJobStore(tmp_path / f"{uuid.uuid4()}.sqlite3")
    yield store
    store.close()


async def test_a_submission_the_store_cannot_take_is_503_with_retry_after(
    inner: SqliteJobStore, make_client: ClientFactory
) -> None:
    down = True
    client = await make_client(store=FlakyStore(inner, lambda name: down), store_retry_after=7)
    r = await client.post("/processes/sleep/execution", json={"inputs": {"seconds": 0}})
    doc = assert_problem(r, 503, "store-unavailable")
    assert r.headers["Retry-After"] == "7"
    assert "nothing was changed" in doc["detail"]
    assert inner.search()[1] == 0  # no job was half made
    down = False
    job = await submit(client, "sleep", {"seconds": 0})
    assert (await wait_for(client, job["jobID"]))["status"] == "successful"


async def test_writes_lost_while_a_job_runs_are_made_by_the_reconciler(
    inner: SqliteJobStore, make_client: ClientFactory
) -> None:
    down = False
    flaky = FlakyStore(inner, lambda name: down and name != "create")
    client = await make_client(store=flaky, reconcile_interval=0.1)
    down = True  # the job's start, progress and end cannot be written
    job = await submit(client, "sleep", {"seconds": 0.3})
    manager = client.app.state.manager  # type: ignore[attr-defined]
    with anyio.fail_after(30):  # the run ends; its start and its result wait to be written
        while "finish" not in [what for what, _, _ in manager._pending]:
            await anyio.sleep(0.02)
    assert "mark_running" in flaky.failed
    assert (await client.get(f"/jobs/{job['jobID']}")).json()["status"] == "accepted"
    down = False
    done = await wait_for(client, job["jobID"])
    assert (done["status"], done["attempts"]) == ("successful", 1)  # not run twice
    assert inner.result(job["jobID"]) is not None


@given(
    schedule=st.lists(
        st.tuples(st.sampled_from(sorted(WRITES - {"create", "create_batch"})), st.booleans()),
        min_size=1,
        max_size=12,
    ),
    jobs=st.integers(min_value=1, max_value=3),
)
@settings(max_examples=8, deadline=None, suppress_health_check=list(HealthCheck))
async def test_random_write_failures_never_strand_a_job(
    make_client: ClientFactory, tmp_path: Path, schedule: list[tuple[str, bool]], jobs: int
) -> None:
    # The n-th write of each kind fails as the schedule says; then the store recovers.
    calls: dict[str, int] = {}
    plan: dict[str, list[bool]] = {}
    for name, fails in schedule:
        plan.setdefault(name, []).append(fails)
    healed = False

    def failing(name: str) -> bool:
        n = calls.get(name, 0)
        calls[name] = n + 1
        steps = plan.get(name, [])
        return not healed and n < len(steps) and steps[n]

    store = SqliteJobStore(tmp_path / f"{uuid.uuid4()}.sqlite3")
    try:
        client = await make_client(store=FlakyStore(store, failing), reconcile_interval=0.05)
        ids = [(await submit(client, "sleep", {"seconds": 0}))["jobID"] for _ in range(jobs)]
        await anyio.sleep(0.3)
        healed = True
        for job_id in ids:
            done = await wait_for(client, job_id, timeout=30)
            assert done["status"] == "successful", done
        ready = (await client.get("/ready")).json()
        assert ready["workers"]["busy"] == 0
        follow = await submit(client, "sleep", {"seconds": 0})
        assert (await wait_for(client, follow["jobID"]))["status"] == "successful"
    finally:
        store.close()


async def test_a_row_with_an_unknown_status_does_not_break_the_list(
    make_client: ClientFactory, tmp_path: Path
) -> None:
    client = await make_client(data_dir=tmp_path / "sqlite")
    job = await submit(client, "sleep", {"seconds": 0})
    await wait_for(client, job["jobID"])
    store = client.app.state.manager.store  # type: ignore[attr-defined]
    store._conn().execute("UPDATE jobs SET status = 'paused' WHERE id = ?", (job["jobID"],))
    r = await client.get("/jobs")
    assert r.status_code == 200, r.text
    [listed] = r.json()["jobs"]
    assert listed["status"] == "failed"
    assert "unknown status 'paused'" in listed["message"]


def test_a_corrupt_store_file_is_one_line_naming_the_file(tmp_path: Path) -> None:
    path = tmp_path / "jobs.sqlite3"
    path.write_bytes(b"this is not a database, it is a poem" * 100)
    with pytest.raises(StoreCorrupt) as err:
        SqliteJobStore(path)
    message = str(err.value)
    assert str(path) in message
    assert "\n" not in message


@contextlib.contextmanager
def small_tmpfs(path: Path, size: str = "1m") -> Iterator[Path]:
    path.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a tmpfs needs root and mount(8)")
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        pytest.skip(f"this machine does not allow mounting a tmpfs: {done.stderr.strip()}")
    try:
        yield path
    finally:
        subprocess.run(["umount", "-l", str(path)], check=False)


def _fill(path: Path) -> None:
    with contextlib.suppress(OSError), path.open("wb") as f:
        while True:
            f.write(b"\0" * 65536)
            f.flush()


async def test_a_full_disk_is_503_then_jobs_complete_when_space_is_back(
    make_client: ClientFactory, tmp_path: Path
) -> None:
    with small_tmpfs(tmp_path / "tiny") as data:
        client = await make_client(data_dir=data, reconcile_interval=0.1)
        first = await submit(
            client, "mesh", {"boundary": SQUARE, "size": 0.5, "smoothing": {"method": "none"}}
        )
        await wait_for(client, first["jobID"])
        _fill(data / "filler")
        refused = 0
        for _ in range(30):  # SQLite may still find room in a page: write until it cannot
            r = await client.post(
                "/processes/sleep/execution", json={"inputs": {"seconds": 0, "marker": "x" * 4000}}
            )
            if r.status_code == 503:
                refused += 1
                assert r.headers["Retry-After"]
                assert_problem(r, 503, "store-unavailable")
                break
            assert r.status_code == 201, r.text
        assert refused, "the full disk never refused a write"
        (data / "filler").unlink()
        job = await submit(client, "sleep", {"seconds": 0})
        assert (await wait_for(client, job["jobID"]))["status"] == "successful"
        records, _ = client.app.state.manager.store.search(limit=100)  # type: ignore[attr-defined]
        assert all(r.status.value in {"successful", "failed"} for r in records), records
        await client.app.state.manager.close()  # type: ignore[attr-defined]
        client.app.state.manager = None  # type: ignore[attr-defined]


async def test_a_job_written_while_the_service_stops_is_left_for_the_next_start(
    make_client: ClientFactory, tmp_path: Path
) -> None:
    """The row of a job is written in a thread; a service that began stopping meanwhile does
    not hand it to a closing backend (which would fail it) but leaves it accepted."""
    data = tmp_path / "sqlite"
    client = await make_client(data_dir=data)
    manager = app_of(client).state.manager
    create = manager.store.create

    def create_while_stopping(job: Any) -> Any:
        manager._closing = True  # the service began stopping during the write
        return create(job)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(manager.store, "create", create_while_stopping)
        job = await submit(client, "sleep", {"seconds": 0})
    manager._closing = False
    assert (await client.get(f"/jobs/{job['jobID']}")).json()["status"] == "accepted"
    assert manager.waiting == 0  # nothing was handed to the backend
    restarted = await make_client(data_dir=data)  # its start recovers the job
    done = await wait_for(restarted, job["jobID"])
    assert done["status"] == "successful", done


def test_closing_waits_for_a_call_in_use_and_refuses_later_ones(tmp_path: Path) -> None:
    # A stopping service closed the store while a callback-state write ran on another thread,
    # and the process crashed (a segmentation fault in SQLite's COMMIT).
    import threading

    from service.jobs.store import NewJob

    store = SqliteJobStore(tmp_path / "jobs.db")
    store.create(NewJob(id="j1", process="mesh", inputs={"size": 0.1}))
    inside, release = threading.Event(), threading.Event()
    real = store._conn

    def held_conn() -> Any:  # the write is in use until the test lets it go on
        inside.set()
        release.wait(10)
        return real()

    store._conn = held_conn  # type: ignore[method-assign]
    writer = threading.Thread(target=store.set_subscriber, args=("j1", {"sent": []}))
    writer.start()
    assert inside.wait(10)
    closer = threading.Thread(target=store.close)
    closer.start()
    closer.join(0.2)
    assert closer.is_alive()  # it waits for the write
    release.set()
    writer.join(10)
    closer.join(10)
    assert not closer.is_alive()
    with pytest.raises(StoreUnavailable, match="closed"):
        store.get("j1")
