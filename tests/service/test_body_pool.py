"""Large request bodies are decoded and validated in a process pool (issue 13, finding 5): the
service keeps answering meanwhile, and the client gets the same answers as from a thread."""

from __future__ import annotations

from typing import Any

import anyio
import httpx
import orjson
import pytest

from .conftest import ClientFactory, assert_problem

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
