"""OGC job list filters (datetime, minDuration, maxDuration, type) and the statusInfo document."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

import httpx
import pytest
from hypothesis import given
from hypothesis import strategies as st

from service.jobfilter import JobFilter
from service.jobs.store import JobRecord, JobStatus

from ..conftest import assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

#: OGC API - Processes 1.0 statusInfo.yaml, as JSON Schema (required fields and typed times).
STATUS_INFO_REQUIRED = {"jobID", "status", "type"}
DATE_TIMES = ("created", "started", "finished", "updated")


def _assert_status_info(doc: dict[str, object]) -> None:
    assert set(doc) >= STATUS_INFO_REQUIRED, doc
    assert doc["type"] == "process"
    assert doc["status"] in {s.value for s in JobStatus}
    for key in DATE_TIMES:
        if key in doc:  # omitted when absent, never null
            value = doc[key]
            assert isinstance(value, str), (key, value)
            assert datetime.fromisoformat(value).tzinfo is not None
    progress = doc["progress"]
    assert isinstance(progress, int)
    assert 0 <= progress <= 100


def _iso(t: float) -> str:
    return datetime.fromtimestamp(t, UTC).isoformat().replace("+00:00", "Z")


def _duration(doc: dict[str, Any]) -> float:
    started = datetime.fromisoformat(doc["started"]).timestamp()
    return datetime.fromisoformat(doc["finished"]).timestamp() - started


async def _ids(client: httpx.AsyncClient, **params: object) -> set[str]:
    r = await client.get("/jobs", params={"limit": 100, **params})
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["numberMatched"] == len(body["jobs"])
    return {j["jobID"] for j in body["jobs"]}


async def test_status_documents_omit_times_not_reached(client: httpx.AsyncClient) -> None:
    job = await submit(client, "sleep", {"seconds": 30})
    _assert_status_info(job)
    assert "finished" not in job
    assert "started" not in job or job["status"] != "accepted"
    await client.delete(f"/jobs/{job['jobID']}")
    quick = await submit(client, "sleep", {"seconds": 0})
    done = await wait_for(client, quick["jobID"])
    _assert_status_info(done)
    assert {"started", "finished"} <= set(done)


async def test_filters(client: httpx.AsyncClient) -> None:
    short = await submit(client, "sleep", {"seconds": 0})
    long = await submit(client, "sleep", {"seconds": 3.0})
    short_done = await wait_for(client, short["jobID"])
    long_done = await wait_for(client, long["jobID"])
    both = {short["jobID"], long["jobID"]}
    assert await _ids(client) == both
    assert await _ids(client, type="process") == both
    assert await _ids(client, type="other") == set()
    # (a worker's first job also imports its runner: durations are measured, not assumed)
    durations = {d["jobID"]: _duration(d) for d in (short_done, long_done)}
    middle = sum(durations.values()) / 2
    assert abs(durations[long["jobID"]] - durations[short["jobID"]]) > 0.1
    assert await _ids(client, minDuration=middle) == {j for j, d in durations.items() if d > middle}
    assert await _ids(client, maxDuration=middle) == {j for j, d in durations.items() if d < middle}
    assert await _ids(client, minDuration=max(durations.values()) + 1) == set()
    created = datetime.fromisoformat(long_done["created"]).timestamp()
    assert await _ids(client, datetime=f"{_iso(created)}/..") == {long["jobID"]}
    assert await _ids(client, datetime=f"../{short_done['created']}") == {short["jobID"]}
    assert await _ids(client, datetime=long_done["created"]) == {long["jobID"]}
    assert await _ids(client, datetime="2000-01-01T00:00:00Z/2000-01-02T00:00:00Z") == set()
    page = (await client.get("/jobs", params={"type": "process", "limit": 1})).json()
    assert page["numberMatched"] == 2
    assert len(page["jobs"]) == 1
    assert [link["rel"] for link in page["links"]].count("next") == 1


async def test_bad_datetime_is_a_400(client: httpx.AsyncClient) -> None:
    r = await client.get("/jobs", params={"datetime": "yesterday"})
    assert_problem(r, 400, "invalid-parameter")


def _record(created: float, started: float | None, finished: float | None) -> JobRecord:
    return JobRecord(
        "j", "mesh", JobStatus.successful, created, created, started=started, finished=finished
    )


@given(
    created=st.floats(0, 2e9),
    run=st.floats(0, 1e4),
    low=st.floats(0, 1e4),
    high=st.floats(0, 1e4),
)
def test_duration_bounds_match_their_definition(
    created: float, run: float, low: float, high: float
) -> None:
    record = _record(created, created, created + run)
    duration = (created + run) - created
    assert JobFilter(min_duration=low).accepts(record) == (duration >= low)
    assert JobFilter(max_duration=high).accepts(record) == (duration <= high)
    assert not JobFilter(min_duration=low).accepts(_record(created, None, None))


@given(millis=st.integers(1, 2 * 10**12), span=st.floats(0, 1e6))
def test_open_intervals_contain_their_start(millis: int, span: float) -> None:
    created = millis / 1000  # stored times are sent at millisecond precision
    record = _record(created, None, None)
    start = _iso(created)
    assert JobFilter.parse(f"{start}/..", None, None, None).accepts(record)
    assert JobFilter.parse(f"{_iso(created + span + 1)}/..", None, None, None).accepts(record) is (
        False
    )
