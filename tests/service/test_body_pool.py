"""Large request bodies are decoded and validated in a process pool (issue 13, finding 5): the
service keeps answering meanwhile, and the client gets the same answers as from a thread."""

from __future__ import annotations

import json
import math
import zlib
from typing import Any

import anyio
import httpx
import orjson
import pytest

from service.jobs.store import JobStatus
from service.jobs.task import Task
from service.routers import batches as batches_router
from service.routers import processes as processes_router

from .conftest import ClientFactory, app_of, assert_problem, wait_for

pytestmark = pytest.mark.anyio


def grid_mesh(side: int) -> dict[str, Any]:
    """A side x side grid mesh (points with non-round coordinates, two triangles a cell)."""
    points = [[i * 1.0123457, j * 0.9876543] for j in range(side) for i in range(side)]
    triangles = []
    for j in range(side - 1):
        for i in range(side - 1):
            a = j * side + i
            triangles += [[a, a + 1, a + side + 1], [a, a + side + 1, a + side]]
    return {"points": points, "triangles": triangles}


def bad_body(side: int) -> bytes:
    """A large quality request whose very last triangle index is a string: validating it walks
    the whole body, and then it is refused with 422 (nothing after validation runs)."""
    mesh = grid_mesh(side)
    mesh["triangles"][-1][2] = "7"
    return orjson.dumps({"inputs": {"mesh": mesh}})


async def health_answers_while(
    client: httpx.AsyncClient, body: bytes
) -> tuple[int, httpx.Response]:
    """``/health`` answers counted while ``body`` is posted, and the POST's response."""
    answers = 0
    done = anyio.Event()
    response: list[httpx.Response] = []

    async def post() -> None:
        response.append(
            await client.post(
                "/processes/quality/execution",
                content=body,
                headers={"Content-Type": "application/json"},
            )
        )
        done.set()

    async with anyio.create_task_group() as tg:
        tg.start_soon(post)
        while not done.is_set():
            r = await client.get("/health")
            assert r.status_code == 200
            answers += 1 if not done.is_set() else 0
    return answers, response[0]


async def test_health_answers_while_a_large_body_is_validated(make_client: ClientFactory) -> None:
    client = await make_client(body_workers=1, body_pool_bytes=1024 * 1024)
    body = bad_body(400)  # about 11 MB
    await client.post(
        "/processes/quality/execution", content=body, headers={"Content-Type": "application/json"}
    )  # the pool has warmed up
    answers, r = await health_answers_while(client, body)
    assert_problem(r, 422, pointer="/inputs/mesh/triangles/318401/2")
    # Validated in a thread (body_workers=0), which holds the GIL through orjson and pydantic,
    # this body let /health answer about 65 times while the pool let it answer about 1,300.
    assert answers >= 300, answers


def _large(mesh_side: int = 60, **extra: Any) -> dict[str, Any]:
    return {"inputs": {"mesh": grid_mesh(mesh_side)}, **extra}


def _nested(depth: int) -> Any:
    value: Any = 1
    for i in range(depth):
        value = [value] if i % 2 else {"x": value}
    return value


#: Bodies over the inline limit (64 KiB) that are refused, one per kind of refusal.
REFUSED = {
    "syntax": orjson.dumps(_large())[:-2] + b",}",
    "too deep": orjson.dumps(_large(outputs=_nested(80))),
    "invalid": bad_body(60),
    "extra member": orjson.dumps(_large(surprise=1)),
    "not an object": orjson.dumps([grid_mesh(60)]),
}


async def test_the_pool_answers_as_the_thread_does(make_client: ClientFactory) -> None:
    pooled = await make_client(body_workers=1, body_pool_bytes=0)
    threaded = await make_client(body_workers=0)
    for name, body in REFUSED.items():
        assert len(body) > 64 * 1024
        answers = [
            await c.post(
                "/processes/quality/execution",
                content=body,
                headers={"Content-Type": "application/json"},
            )
            for c in (pooled, threaded)
        ]
        assert answers[0].status_code in (400, 422), (name, answers[0].text)
        assert answers[0].headers["content-type"] == answers[1].headers["content-type"], name
        assert (answers[0].status_code, answers[0].json()) == (
            answers[1].status_code,
            answers[1].json(),
        ), name


async def test_a_large_valid_body_is_accepted_through_the_pool(make_client: ClientFactory) -> None:
    client = await make_client(body_workers=1, body_pool_bytes=0)
    r = await client.post("/processes/quality/execution", json=_large())
    assert r.status_code == 201, r.text


def _bowtie_body(vertices: int) -> bytes:
    """A large ``mesh`` request whose ring crosses itself: refused after validation."""
    ring = [
        [math.cos(2 * math.pi * k / vertices), math.sin(2 * math.pi * k / vertices)]
        for k in range(vertices)
    ]
    ring[10], ring[vertices // 2] = ring[vertices // 2], ring[10]
    boundary = {"type": "Polygon", "coordinates": [ring]}
    return orjson.dumps({"inputs": {"boundary": boundary, "size": 0.1}})


def _inverted_body(side: int) -> bytes:
    mesh = grid_mesh(side)
    a, b, c = mesh["triangles"][7]
    mesh["triangles"][7] = [a, c, b]
    return orjson.dumps({"inputs": {"mesh": mesh}})


#: Large bodies refused after validation, by the admission a pool process runs (issue 13's
#: missed item: the whole admission of a large body runs there).
REFUSED_BY_ADMISSION = {
    "crossing ring": ("mesh", _bowtie_body(4000)),
    "inverted triangle": ("quality", _inverted_body(60)),
    "over a limit": ("smooth", orjson.dumps(_large(80))),
}


async def test_the_pools_admission_answers_as_the_thread_does(make_client: ClientFactory) -> None:
    limits = {"max_triangles": 10_000}
    pooled = await make_client(body_workers=1, body_pool_bytes=0, **limits)
    threaded = await make_client(body_workers=0, **limits)
    for name, (process, body) in REFUSED_BY_ADMISSION.items():
        assert len(body) > 64 * 1024
        answers = [
            await c.post(
                f"/processes/{process}/execution",
                content=body,
                headers={"Content-Type": "application/json"},
            )
            for c in (pooled, threaded)
        ]
        assert answers[0].status_code == 422, (name, answers[0].text)
        assert answers[0].json() == answers[1].json(), name


async def test_a_large_body_is_admitted_in_the_pool_not_in_the_api_process(
    make_client: ClientFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    client = await make_client(body_workers=1, body_pool_bytes=0)

    async def nowhere(*args: Any) -> Any:
        raise AssertionError("prepared in the API process")

    monkeypatch.setattr(processes_router, "off_loop", nowhere)
    body = {"inputs": {"mesh": grid_mesh(60), "smoothing": {"method": "laplacian", "seed": 3}}}
    key = {"Idempotency-Key": "large-1"}
    first = await client.post("/processes/smooth/execution", json=body, headers=key)
    assert first.status_code == 201, first.text
    again = await client.post("/processes/smooth/execution", json=body, headers=key)
    assert again.headers["Idempotent-Replayed"] == "true"
    assert again.headers["Location"] == first.headers["Location"]
    other = {"inputs": {**body["inputs"], "smoothing": {"method": "laplacian", "seed": 4}}}
    conflict = await client.post("/processes/smooth/execution", json=other, headers=key)
    assert_problem(conflict, 422)


#: Bigger than any status answer or small encoding of the test, smaller than the body below.
_LARGE = 256 * 1024


def large_codec_calls(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, int]]:
    """``(codec, size)`` of every JSON or zlib call of this process on more than ``_LARGE``
    bytes from now on."""
    large: list[tuple[str, int]] = []

    def counted(module: Any, name: str) -> None:
        real = getattr(module, name)

        def call(data: Any, *args: Any, **kwargs: Any) -> Any:
            out = real(data, *args, **kwargs)
            size = max(len(x) if isinstance(x, bytes | str) else 0 for x in (data, out))
            if size > _LARGE:
                large.append((f"{module.__name__}.{name}", size))
            return out

        monkeypatch.setattr(module, name, call)

    for module, names in ((orjson, ("dumps", "loads")), (json, ("dumps", "loads"))):
        for name in names:
            counted(module, name)
    for name in ("compress", "decompress"):
        counted(zlib, name)
    return large


def payload_types(client: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch) -> list[type]:
    """The type of the payload of every task the client's backend is handed from now on."""
    handed: list[type] = []
    backend = app_of(client).state.manager.backend
    submit = backend.submit

    def hand(task: Task) -> None:
        handed.append(type(task.payload))
        submit(task)

    monkeypatch.setattr(backend, "submit", hand)
    return handed


async def test_a_large_accepted_body_is_neither_decoded_nor_encoded_in_the_api_process(
    make_client: ClientFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Admitted in the pool, a large request reaches the store and the worker as the bytes the
    pool encoded: the API process runs no JSON or zlib codec on anything that large (the old
    way: the store encoded the inputs on the event loop, the backend pickled them as a tree)."""
    client = await make_client(body_workers=1, body_pool_bytes=0, backend="local")
    body = orjson.dumps({"inputs": {"mesh": grid_mesh(150)}})
    assert len(body) > 4 * _LARGE
    large = large_codec_calls(monkeypatch)
    handed = payload_types(client, monkeypatch)
    r = await client.post(
        "/processes/quality/execution", content=body, headers={"Content-Type": "application/json"}
    )
    assert r.status_code == 201, r.text
    job = await wait_for(client, r.json()["jobID"])
    assert job["status"] == "successful", job  # the worker decoded what it was handed
    assert handed == [bytes]
    assert large == []


def _batch_body(members: int, side: int, **extra: Any) -> dict[str, Any]:
    """A ``/batches`` request of ``members`` quality requests, each a side x side grid."""
    requests = [{"inputs": {"mesh": grid_mesh(side)}} for _ in range(members)]
    return {"process": "quality", "requests": requests, **extra}


async def test_a_large_batch_is_admitted_in_the_pool_and_not_coded_in_the_api_process(
    make_client: ClientFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A large batch goes the way a large single request goes: admitted whole in the pool, each
    item's inputs encoded there, written in a thread, handed to the workers as those bytes."""
    client = await make_client(body_workers=1, body_pool_bytes=0, backend="local")

    async def nowhere(*args: Any) -> Any:
        raise AssertionError("prepared in the API process")

    monkeypatch.setattr(batches_router, "off_loop", nowhere)
    body = orjson.dumps(_batch_body(3, 100))
    assert len(body) > 6 * _LARGE
    large = large_codec_calls(monkeypatch)
    handed = payload_types(client, monkeypatch)
    r = await client.post("/batches", content=body, headers={"Content-Type": "application/json"})
    assert r.status_code == 201, r.text
    jobs = [await wait_for(client, job["jobID"]) for job in r.json()["jobs"]]
    assert [job["status"] for job in jobs] == ["successful"] * 3  # the workers decoded them
    assert handed == [bytes] * 3
    assert large == []
    result = (await client.get(f"/jobs/{jobs[2]['jobID']}/results")).json()
    assert len(result["triangles"]) == 2 * 99 * 99


def _batch_refusals() -> dict[str, bytes]:
    """Large batches refused, one per kind of refusal: by the body's shape, by an item's
    validation, by an item's admission, by the batch's limits."""
    inverted = _batch_body(2, 60)
    a, b, c = inverted["requests"][1]["inputs"]["mesh"]["triangles"][7]
    inverted["requests"][1]["inputs"]["mesh"]["triangles"][7] = [a, c, b]
    mistyped = _batch_body(2, 60)
    mistyped["requests"][1]["inputs"]["mesh"]["triangles"][-1][2] = "7"
    return {
        "both forms": orjson.dumps(_batch_body(2, 60, features=[{"type": "Feature"}])),
        "item invalid": orjson.dumps(mistyped),
        "item inputs not an object": orjson.dumps(
            {**_batch_body(2, 60), "requests": [{"inputs": [grid_mesh(60)]}]}
        ),
        "item refused by admission": orjson.dumps(inverted),
        "no such process": orjson.dumps({**_batch_body(2, 60), "process": "nope"}),
        "over the item limit": orjson.dumps(_batch_body(4, 60)),
        "a collection not meshed": orjson.dumps(
            {"type": "FeatureCollection", "features": [grid_mesh(60)], "process": "quality"}
        ),
    }


async def test_the_pools_batch_admission_answers_as_the_thread_does(
    make_client: ClientFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    limits = {"max_batch_items": 3}
    pooled = await make_client(body_workers=1, body_pool_bytes=0, **limits)
    threaded = await make_client(body_workers=0, **limits)
    real_off_loop = batches_router.off_loop

    async def nowhere(*args: Any) -> Any:
        raise AssertionError("prepared in the API process")

    for name, body in _batch_refusals().items():
        assert len(body) > 64 * 1024
        answers = []
        for client, off_loop in ((pooled, nowhere), (threaded, real_off_loop)):
            monkeypatch.setattr(batches_router, "off_loop", off_loop)
            answers.append(
                await client.post(
                    "/batches", content=body, headers={"Content-Type": "application/json"}
                )
            )
        assert answers[0].status_code in (404, 422), (name, answers[0].text)
        assert (answers[0].status_code, answers[0].json()) == (
            answers[1].status_code,
            answers[1].json(),
        ), name
    assert app_of(pooled).state.manager.store.counts()[JobStatus.accepted] == 0
