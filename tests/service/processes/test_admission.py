"""Admission (issue 13, findings 2 and 7): the engine's estimator and limits, strict numbers,
sizes that would underflow or mean nothing, parameters the engine refuses, media types, hosts."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest

import engine
from service import processes
from service.geojson import LocatedInvalidBoundary
from service.jobs.task import TaskError
from service.problems import problem_for
from service.processes import PROCESSES, estimate_mesh, inputs_at
from service.refusal import InputRefused
from service.settings import Settings

from ..conftest import SQUARE, ClientFactory, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

NONE = {"method": "none"}


async def _execute(client: httpx.AsyncClient, inputs: dict[str, Any]) -> httpx.Response:
    return await client.post("/processes/mesh/execution", json={"inputs": inputs})


def _settings(**values: Any) -> Settings:
    return Settings(_env_file=None, **values)  # type: ignore[call-arg]


def test_admission_uses_the_engines_estimate() -> None:
    model = PROCESSES["mesh"].inputs_model.model_validate(
        {"boundary": SQUARE, "size": 0.05, "smoothing": NONE}
    )
    prepared = PROCESSES["mesh"].prepare(model, _settings(), inputs_at("/inputs"))
    region = engine.make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    assert prepared.triangles == estimate_mesh(region, engine.SizingParams(0.05))
    assert prepared.inputs["max_triangles"] == _settings().max_triangles


def test_the_ga_work_limit_becomes_the_workers_triangle_limit() -> None:
    settings = _settings(max_ga_work=2e6, max_triangles=1_000_000)
    smoothing = {"method": "ga", "population": 10, "generations": 10, "max_sweeps": 10}
    model = PROCESSES["mesh"].inputs_model.model_validate(
        {"boundary": SQUARE, "size": 0.5, "smoothing": smoothing}
    )
    prepared = PROCESSES["mesh"].prepare(model, settings, inputs_at("/inputs"))
    assert prepared.inputs["max_triangles"] == 2 * 2_000_000 // 1000
    # ... and consistent with the time limit: no more work than job_timeout x ga_rate.
    short = _settings(max_ga_work=1e12, ga_rate=1e6, job_timeout=10)
    assert short.ga_work_limit == 1e7


def test_the_worker_enforces_the_services_triangle_limit_on_the_real_mesh() -> None:
    payload = {
        "parts": [([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], [])],
        "coordinates": "planar",
        "size": 0.05,
        "growth": 1.2,
        "size_min": None,
        "size_max": None,
        "swap": False,
        "smoothing": {"method": "none", "seed": 1},
        "max_triangles": 50,  # the engine's own default is 5,000,000
    }
    with pytest.raises(TaskError, match="limit of 50"):
        processes.run("mesh", payload, lambda p, m: None, lambda: False)
    payload["max_triangles"] = 100_000
    _, figures = processes.run("mesh", payload, lambda p, m: None, lambda: False)
    assert figures["triangles"] > 50


async def test_an_estimate_over_max_triangles_is_422_saying_what_to_change(
    make_client: ClientFactory,
) -> None:
    client = await make_client(max_triangles=100)
    doc = assert_problem(
        await _execute(client, {"boundary": SQUARE, "size": 0.01, "smoothing": NONE}),
        422,
        "limit-exceeded",
        "/inputs/size",
    )
    assert "estimated number of triangles" in doc["detail"]


@pytest.mark.parametrize(
    ("inputs", "pointer"),
    [
        ({"size": 1e-200}, "/inputs/size"),  # underflows when squared
        ({"size": 1e-160}, "/inputs/size"),
        ({"size": 1e308}, "/inputs/size"),  # overflows when squared
        ({"size": 1e-9}, "/inputs/size"),  # 2e18 triangles: refused before the size field
        ({"size": 0.1, "size_min": 1e-300}, "/inputs/size_min"),
        ({"size": 0.1, "size_max": 1e300}, "/inputs/size_max"),
        (
            {"size": 0.1, "smoothing": {"fitness": "combined", "alpha": 0, "beta": 0}},
            "/inputs/smoothing",
        ),
    ],
)
async def test_values_the_worker_would_fail_on_are_422_at_admission(
    client: httpx.AsyncClient, inputs: dict[str, Any], pointer: str
) -> None:
    assert_problem(await _execute(client, {"boundary": SQUARE, **inputs}), 422, pointer=pointer)


async def test_quality_with_alpha_and_beta_zero_is_422(client: httpx.AsyncClient) -> None:
    mesh = {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 1, 2]]}
    r = await client.post(
        "/processes/quality/execution",
        json={"inputs": {"mesh": mesh, "fitness": "combined", "alpha": 0, "beta": 0}},
    )
    assert_problem(r, 422, "invalid-input")


@pytest.mark.parametrize(
    ("inputs", "pointer"),
    [
        ({"size": "0.5"}, "/inputs/size"),
        ({"size": True}, "/inputs/size"),
        ({"size": 0.5, "swap": "true"}, "/inputs/swap"),
        ({"size": 0.5, "swap": 1}, "/inputs/swap"),
        ({"size": 0.5, "smoothing": {"population": "20"}}, "/inputs/smoothing/population"),
        ({"size": 0.5, "smoothing": {"population": 20.5}}, "/inputs/smoothing/population"),
        ({"size": 0.5, "smoothing": {"seed": "7"}}, "/inputs/smoothing/seed"),
    ],
)
async def test_numbers_and_flags_are_strict(
    client: httpx.AsyncClient, inputs: dict[str, Any], pointer: str
) -> None:
    assert_problem(await _execute(client, {"boundary": SQUARE, **inputs}), 422, pointer=pointer)


async def test_integers_are_numbers(client: httpx.AsyncClient) -> None:
    job = await submit(client, "mesh", {"boundary": SQUARE, "size": 1, "smoothing": NONE})
    assert (await wait_for(client, job["jobID"]))["status"] == "successful"


@pytest.mark.parametrize("content_type", ["text/plain", "application/x-www-form-urlencoded", None])
async def test_a_body_that_is_not_declared_json_is_415(
    client: httpx.AsyncClient, content_type: str | None
) -> None:
    body = json.dumps({"inputs": {"boundary": SQUARE, "size": 0.5}})
    headers = {"Content-Type": content_type} if content_type else {}
    for path in ("/processes/mesh/execution", "/batches"):
        r = await client.post(path, content=body, headers=headers)
        assert_problem(r, 415, "unsupported-media-type")
    r = await client.post(
        "/processes/mesh/execution",
        content=body,
        headers={"Content-Type": "application/geo+json; charset=utf-8"},
    )
    assert r.status_code == 201, r.text


async def test_the_host_header_is_not_echoed_into_location(make_client: ClientFactory) -> None:
    client = await make_client(public_url="https://meshes.example.org/api")
    inputs = {"boundary": SQUARE, "size": 0.5, "smoothing": NONE}
    r = await client.post(
        "/processes/mesh/execution", json={"inputs": inputs}, headers={"Host": "evil.example"}
    )
    assert r.status_code == 201, r.text
    assert r.headers["Location"].startswith("https://meshes.example.org/api/jobs/")
    assert "evil" not in r.text


async def test_an_untrusted_host_is_refused(make_client: ClientFactory, tmp_path: Path) -> None:
    client = await make_client(trusted_hosts="testserver,api.example.org")
    inputs = {"inputs": {"boundary": SQUARE, "size": 0.5, "smoothing": NONE}}
    r = await client.post(
        "/processes/mesh/execution", json=inputs, headers={"Host": "evil.example"}
    )
    assert r.status_code == 400
    assert "evil" not in r.headers.get("location", "")
    r = await client.post(
        "/processes/mesh/execution", json=inputs, headers={"Host": "api.example.org"}
    )
    assert r.headers["Location"].startswith("http://api.example.org/jobs/")


async def test_a_job_waits_for_a_warm_worker_and_ready_says_so(
    make_client: ClientFactory,
) -> None:
    client = await make_client(backend="local")  # worker processes, which warm up
    ready = (await client.get("/ready")).json()  # the fixture waited for /ready
    manager = client.app.state.manager  # type: ignore[attr-defined]
    stats = manager.backend.stats()
    assert stats.ready == stats.workers == ready["workers"]["configured"]
    assert all(w.ready for w in manager.backend._pool)


def test_the_region_in_a_payload_survives_a_round_trip() -> None:
    # What is stored is plain data: rebuilding the region from it gives the same region.
    model = PROCESSES["mesh"].inputs_model.model_validate(
        {"boundary": SQUARE, "size": 0.5, "coordinates": "planar", "smoothing": NONE}
    )
    prepared = PROCESSES["mesh"].prepare(model, _settings(), inputs_at("/inputs"))
    stored = json.loads(json.dumps(prepared.inputs))
    from service.geojson import build_region

    region = build_region(stored["parts"])
    assert np.isclose(region.area, 1.0)


async def test_a_size_the_coordinates_cannot_resolve_is_a_422_not_a_server_error(
    client: httpx.AsyncClient,
) -> None:
    # A square 1e-6 wide at 1e9 meshed at 1e-7: the job failed on an internal ZeroDivisionError.
    ring = [[1e9 + x * 1e-6, 1e9 + y * 1e-6] for x, y in [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]
    boundary = {"type": "Polygon", "coordinates": [ring]}
    doc = assert_problem(
        await _execute(client, {"boundary": boundary, "size": 1e-7}),
        422,
        "limit-exceeded",
        "/inputs/size",
    )
    assert "resolved only to" in doc["detail"]


def test_coordinates_near_the_float_limit_are_a_422_not_a_server_error() -> None:
    # Differences of such numbers overflow (a RuntimeWarning, an error under -W error).
    ring = [[-1.7e308, 0.0], [1.7e308, 0.0], [0.0, 1.7e308]]
    model = PROCESSES["mesh"].inputs_model.model_validate(
        {"boundary": {"type": "Polygon", "coordinates": [ring]}, "size": 1.0}
    )
    # Refused as an InputRefused or as the engine's typed InvalidBoundary located in the input,
    # which the service's one mapper (problems.problem_for) turns into a 422 with a message.
    with pytest.raises((InputRefused, LocatedInvalidBoundary)) as info:
        PROCESSES["mesh"].prepare(model, _settings(), inputs_at("/inputs"))
    assert problem_for(info.value).status == 422
