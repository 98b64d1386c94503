"""Pictures (issue 13, finding 5): options and size checked before the result is loaded,
rendered in a bounded pool, once per job and options."""

from __future__ import annotations

import anyio
import httpx
import pytest

from ..conftest import SQUARE, ClientFactory, app_of, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio


async def _mesh(client: httpx.AsyncClient) -> str:
    job = await submit(
        client, "mesh", {"boundary": SQUARE, "size": 0.25, "smoothing": {"method": "none"}}
    )
    assert (await wait_for(client, job["jobID"]))["status"] == "successful"
    return str(job["jobID"])


async def test_a_picture_over_the_size_limit_is_refused_before_loading(
    client: httpx.AsyncClient,
) -> None:
    job_id = await _mesh(client)
    store = app_of(client).state.manager.store
    loads: list[str] = []
    real = store.result

    def counted(job: str) -> bytes | None:
        loads.append(job)
        return real(job)

    store.result = counted
    try:
        url = f"/jobs/{job_id}/results"
        r = await client.get(url, params={"f": "png", "width": "8000", "height": "8000"})
        doc = assert_problem(r, 400, "invalid-parameter")
        assert "max_picture_pixels" in doc["detail"]
        assert_problem(await client.get(url, params={"f": "png", "width": "x"}), 400)
        assert loads == []  # refused without touching the stored result
        # Also before looking the job up: an unknown job with bad options is the options' 400.
        assert_problem(
            await client.get("/jobs/nope/results", params={"f": "svg", "worst": "-1"}), 400
        )
    finally:
        store.result = real


async def test_a_picture_is_rendered_once_per_job_and_options(client: httpx.AsyncClient) -> None:
    job_id = await _mesh(client)
    pool = app_of(client).state.render_pool
    url = f"/jobs/{job_id}/results"
    first = await client.get(url, params={"f": "png", "width": "300", "height": "200"})
    assert first.status_code == 200
    store = app_of(client).state.manager.store
    real = store.result
    store.result = lambda job: pytest.fail("the cached picture was loaded again")  # type: ignore[assignment]
    try:
        again = await client.get(url, params={"height": "200", "f": "png", "width": "300"})
    finally:
        store.result = real
    assert again.content == first.content
    other = await client.get(url, params={"f": "png", "width": "300", "height": "300"})
    assert other.status_code == 200
    assert other.content != first.content
    assert len(pool._cache) == 2
    # A dismissed job's picture is gone with it, cached or not.
    await client.delete(f"/jobs/{job_id}")
    r = await client.get(url, params={"f": "png", "width": "300", "height": "200"})
    assert_problem(r, 410)


async def test_renders_run_at_most_render_workers_at_once(make_client: ClientFactory) -> None:
    client = await make_client(render_workers=1)
    job_id = await _mesh(client)
    pool = app_of(client).state.render_pool
    url = f"/jobs/{job_id}/results"
    peak = 0

    async def one(width: int) -> None:
        nonlocal peak
        r = await client.get(url, params={"f": "png", "width": str(width), "height": "300"})
        assert r.status_code == 200
        assert pool._limiter is not None
        peak = max(peak, pool._limiter.borrowed_tokens)

    async with anyio.create_task_group() as tg:
        for width in (400, 410, 420, 430):
            tg.start_soon(one, width)
    assert pool._limiter.total_tokens == 1
    assert peak <= 1
    assert len(pool._cache) == 4
