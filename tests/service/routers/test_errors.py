"""Every error is an RFC 9457 problem, pointing at the offending input; limits are enforced."""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from typing import Any

import httpx
import pytest

import engine

from ..conftest import SQUARE, ClientFactory, assert_problem, submit

pytestmark = pytest.mark.anyio

NONE = {"method": "none"}


async def _execute(
    client: httpx.AsyncClient, inputs: dict[str, Any], process: str = "mesh"
) -> httpx.Response:
    return await client.post(f"/processes/{process}/execution", json={"inputs": inputs})


async def test_validation_errors_are_problems_with_pointers(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"boundary": SQUARE, "size": "big", "smoothing": {"population": 1}})
    doc = assert_problem(r, 422, "invalid-input")
    pointers = {e["pointer"] for e in doc["errors"]}
    assert pointers == {"/inputs/size", "/inputs/smoothing/population"}
    assert doc["pointer"] in pointers
    assert all(e["detail"] for e in doc["errors"])
    r = await _execute(client, {"boundary": SQUARE, "size": 0.1, "smoothing": {"method": "nope"}})
    assert_problem(r, 422, "invalid-input", "/inputs/smoothing/method")
    r = await _execute(client, {"boundary": SQUARE, "size": 0.1, "colour": "red"})
    assert_problem(r, 422, "invalid-input", "/inputs/colour")
    assert_problem(await client.post("/processes/mesh/execution", json={}), 422, pointer="/inputs")


async def test_malformed_json_and_non_finite_numbers(client: httpx.AsyncClient) -> None:
    headers = {"Content-Type": "application/json"}
    r = await client.post("/processes/mesh/execution", content=b'{"inputs": ', headers=headers)
    doc = assert_problem(r, 400, "invalid-json")
    assert (doc["line"], doc["column"]) == (1, 12)
    assert "pointer" not in doc  # an offset is not a JSON pointer
    # NaN is not JSON: refused where it stands (line 2 here), not turned into a number.
    text = '{"inputs": {"boundary": ' + json.dumps(SQUARE) + ',\n "size": NaN}}'
    r = await client.post("/processes/mesh/execution", content=text, headers=headers)
    doc = assert_problem(r, 400, "invalid-json")
    assert (doc["line"], doc["column"]) == (2, 10)
    assert "line 2, column 10" in doc["detail"]


async def test_self_intersection_points_at_the_vertex(client: httpx.AsyncClient) -> None:
    ring = [[0, 0], [2, 0], [2, 1], [1, 1], [1.5, -0.5], [0, 1], [0, 0]]
    r = await _execute(
        client, {"boundary": {"type": "Polygon", "coordinates": [ring]}, "size": 0.1}
    )
    doc = assert_problem(r, 422, "invalid-boundary")
    assert doc["pointer"].startswith("/inputs/boundary/coordinates/0/")
    assert "intersects itself" in doc["detail"]
    assert len(doc["location"]) == 2


async def test_malformed_boundaries(client: httpx.AsyncClient) -> None:
    cases = [
        ({"type": "Point", "coordinates": [0, 0]}, "/inputs/boundary/type"),
        (
            {"type": "Polygon", "coordinates": [[[0, 0], [1, "x"], [1, 1]]]},
            "/inputs/boundary/coordinates/0/1",
        ),
        ({"outer": [[0, 0], [1, 0], [1, 1]], "holes": "none"}, "/inputs/boundary/holes"),
        ("a string", "/inputs/boundary"),
        ({"type": "Feature", "geometry": None}, "/inputs/boundary/geometry"),
    ]
    for boundary, pointer in cases:
        r = await _execute(client, {"boundary": boundary, "size": 0.1})
        assert_problem(r, 422, "invalid-boundary", pointer)


async def test_size_is_required_without_an_h_property(client: httpx.AsyncClient) -> None:
    assert_problem(await _execute(client, {"boundary": SQUARE}), 422, pointer="/inputs/size")
    feature = {"type": "Feature", "properties": {"h": "big"}, "geometry": SQUARE}
    assert_problem(await _execute(client, {"boundary": feature}), 422, pointer="/inputs/size")
    r = await _execute(client, {"boundary": SQUARE, "size": 0.1, "size_min": 0.5, "size_max": 0.2})
    assert_problem(r, 422, pointer="/inputs/size")


async def test_default_smoothing_method_is_the_ga(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"boundary": SQUARE, "size": 0.5})
    if "ga" in engine.SMOOTHERS:
        assert r.status_code == 201, r.text
    else:  # until the GA is merged the documented default is refused, not run and failed
        assert_problem(r, 422, pointer="/inputs/smoothing/method")


async def test_invalid_mesh_inputs(client: httpx.AsyncClient) -> None:
    inverted = {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 2, 1]]}
    r = await _execute(client, {"mesh": inverted, "smoothing": NONE}, "smooth")
    assert_problem(r, 422, "invalid-mesh", "/inputs/mesh/triangles/0")
    out_of_range = {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 1, 5]]}
    assert_problem(await _execute(client, {"mesh": out_of_range}, "quality"), 422, "invalid-mesh")
    short = {"points": [[0, 0], [1, 0], [0]], "triangles": [[0, 1, 2]]}
    assert_problem(
        await _execute(client, {"mesh": short}, "quality"), 422, pointer="/inputs/mesh/points/2"
    )


@pytest.fixture
async def limited(make_client: ClientFactory) -> httpx.AsyncClient:
    return await make_client(
        max_vertices=50, max_rings=2, max_triangles=1000, max_ga_work=1e6, max_body_bytes=20_000
    )


async def test_vertex_ring_and_triangle_limits(limited: httpx.AsyncClient) -> None:
    many = [[float(i), 0.0] for i in range(60)] + [[30.0, 10.0]]
    r = await _execute(limited, {"boundary": {"outer": many}, "size": 1.0})
    doc = assert_problem(r, 422, "limit-exceeded", "/inputs/boundary")
    assert "vertices" in doc["detail"]
    hole = [[0.2, 0.2], [0.3, 0.2], [0.3, 0.3]]
    rings = {
        "type": "Polygon",
        "coordinates": [SQUARE["coordinates"][0], hole, [[0.6, 0.6], [0.7, 0.6], [0.7, 0.7]]],
    }
    assert_problem(
        await _execute(limited, {"boundary": rings, "size": 0.1}),
        422,
        "limit-exceeded",
        "/inputs/boundary",
    )
    r = await _execute(limited, {"boundary": SQUARE, "size": 0.01, "smoothing": NONE})
    doc = assert_problem(r, 422, "limit-exceeded", "/inputs/size")
    assert "triangles" in doc["detail"]
    assert (
        await _execute(limited, {"boundary": SQUARE, "size": 0.1, "smoothing": NONE})
    ).status_code == 201


async def test_ga_work_limit(limited: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch) -> None:
    # Validation runs in this process: pretend the GA is installed to reach the work check.
    monkeypatch.setitem(engine.SMOOTHERS, "ga", engine.SMOOTHERS["none"])
    r = await _execute(limited, {"boundary": SQUARE, "size": 0.1, "smoothing": {"method": "ga"}})
    doc = assert_problem(r, 422, "limit-exceeded", "/inputs/smoothing")
    assert "GA work" in doc["detail"]


async def test_body_limit_with_content_length(limited: httpx.AsyncClient) -> None:
    big = {"inputs": {"boundary": SQUARE, "size": 0.1, "pad": "x" * 30_000}}
    assert_problem(await limited.post("/processes/mesh/execution", json=big), 413)


async def test_body_limit_while_streaming(limited: httpx.AsyncClient) -> None:
    sent = 0

    async def chunks() -> AsyncIterator[bytes]:
        nonlocal sent
        yield b'{"inputs": {"pad": "'
        for _ in range(1000):  # 1 MB offered; the server stops reading after the limit
            sent += 1
            yield b"x" * 1000
        yield b'"}}'

    r = await limited.post(
        "/processes/mesh/execution", content=chunks(), headers={"Content-Type": "application/json"}
    )
    assert_problem(r, 413)
    assert sent < 100  # refused while streaming, not after reading everything


async def test_idempotency_key_must_be_a_token(client: httpx.AsyncClient) -> None:
    body = {"inputs": {"boundary": SQUARE, "size": 0.5, "smoothing": NONE}}
    r = await client.post(
        "/processes/mesh/execution", json=body, headers={"Idempotency-Key": "x" * 300}
    )
    assert_problem(r, 422)


async def test_job_ids_are_opaque(client: httpx.AsyncClient) -> None:
    job = await submit(client, "mesh", {"boundary": SQUARE, "size": 0.5, "smoothing": NONE})
    assert len(job["jobID"]) == 36
    assert_problem(await client.get("/jobs/' OR 1=1 --"), 404, "no-such-job")
