"""Batches: a FeatureCollection or execute requests with shared defaults, all or nothing."""

from __future__ import annotations

from typing import Any

import httpx
import pytest

from tests.conftest import load_case

from ..conftest import SQUARE, assert_problem, wait_for

pytestmark = pytest.mark.anyio

NONE = {"method": "none"}


async def _wait_batch(client: httpx.AsyncClient, batch: dict[str, Any]) -> dict[str, Any]:
    for job in batch["jobs"]:
        await wait_for(client, job["jobID"])
    r = await client.get(f"/batches/{batch['batchID']}")
    assert r.status_code == 200
    doc: dict[str, Any] = r.json()
    return doc


async def test_feature_collection_batch_one_job_per_feature(client: httpx.AsyncClient) -> None:
    features = [load_case(name) for name in ("l_shape", "unit_square", "letter_a")]
    body = {"type": "FeatureCollection", "features": features, "inputs": {"smoothing": NONE}}
    r = await client.post("/batches", json=body)
    assert r.status_code == 201, r.text
    batch = r.json()
    assert r.headers["location"].endswith(f"/batches/{batch['batchID']}")
    assert len(batch["jobs"]) == 3
    assert batch["counts"]["accepted"] + batch["counts"]["running"] >= 1
    done = await _wait_batch(client, batch)
    assert done["status"] == "successful"
    assert done["progress"] == 100
    assert done["counts"]["successful"] == 3
    for job, feature in zip(done["jobs"], features, strict=True):
        result = (await client.get(f"/jobs/{job['jobID']}/results")).json()
        # each feature's own h property gave its size
        assert result["summary"]["parameters"]["sizing"]["size"] == feature["properties"]["h"]


async def test_request_list_with_shared_defaults(client: httpx.AsyncClient) -> None:
    body = {
        "process": "mesh",
        "inputs": {"boundary": SQUARE, "size": 0.5, "smoothing": {"method": "none", "seed": 11}},
        "requests": [{"inputs": {}}, {"inputs": {"size": 0.25, "smoothing": {"seed": 12}}}],
    }
    r = await client.post("/batches", json=body)
    assert r.status_code == 201, r.text
    done = await _wait_batch(client, r.json())
    seeds, sizes = [], []
    for job in done["jobs"]:
        status = (await client.get(f"/jobs/{job['jobID']}")).json()
        params = (await client.get(f"/jobs/{job['jobID']}/results")).json()["summary"]["parameters"]
        seeds.append(status["seed"])
        sizes.append(params["sizing"]["size"])
        assert params["smoothing"]["method"] == "none"  # the shared default, merged
    assert seeds == [11, 12]
    assert sizes == [0.5, 0.25]


async def test_a_bad_item_refuses_the_whole_batch(client: httpx.AsyncClient) -> None:
    bowtie = {"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]}
    good = {"type": "Feature", "properties": {"h": 0.2}, "geometry": SQUARE}
    bad = {"type": "Feature", "properties": {"h": 0.2}, "geometry": bowtie}
    r = await client.post(
        "/batches",
        json={"type": "FeatureCollection", "features": [good, bad], "inputs": {"smoothing": NONE}},
    )
    doc = assert_problem(r, 422, "invalid-boundary")
    assert doc["pointer"].startswith("/features/1/geometry/coordinates/0")
    r = await client.post(
        "/batches",
        json={
            "inputs": {"boundary": SQUARE, "smoothing": NONE},
            "requests": [{"inputs": {"size": 0.5}}, {"inputs": {"size": -1}}],
        },
    )
    assert_problem(r, 422, "invalid-input", "/requests/1/inputs/size")
    r = await client.post("/batches", json={"requests": [{"inputs": {"size": 0.5}}]})
    assert_problem(r, 422, "invalid-input", "/requests/0/inputs/boundary")
    assert (await client.get("/jobs")).json()["numberMatched"] == 0  # nothing was created


async def test_batch_shape_errors(client: httpx.AsyncClient) -> None:
    assert_problem(await client.post("/batches", json={}), 422)
    both = {"type": "FeatureCollection", "features": [SQUARE], "requests": [{"inputs": {}}]}
    assert_problem(await client.post("/batches", json=both), 422)
    r = await client.post("/batches", json={"process": "nope", "requests": [{"inputs": {}}]})
    assert_problem(r, 404, "no-such-process", "/process")
    r = await client.post(
        "/batches", json={"type": "FeatureCollection", "features": [SQUARE], "process": "quality"}
    )
    assert_problem(r, 422, pointer="/process")
    assert_problem(await client.get("/batches/nope"), 404, "no-such-batch")
    assert_problem(await client.delete("/batches/nope"), 404, "no-such-batch")


async def test_batch_item_limit(make_client: Any) -> None:
    client = await make_client(max_batch_items=2)
    body = {
        "inputs": {"boundary": SQUARE, "size": 0.5, "smoothing": NONE},
        "requests": [{}, {}, {}],
    }
    assert_problem(await client.post("/batches", json=body), 422, "limit-exceeded", "/requests")


async def test_dismiss_a_batch(client: httpx.AsyncClient) -> None:
    body = {"process": "sleep", "inputs": {"seconds": 30}, "requests": [{}, {}, {}]}
    r = await client.post("/batches", json=body)
    assert r.status_code == 201, r.text
    batch = r.json()
    await wait_for(client, batch["jobs"][0]["jobID"], {"running"})
    running = (await client.get(f"/batches/{batch['batchID']}")).json()
    assert running["status"] == "running"
    r = await client.delete(f"/batches/{batch['batchID']}")
    assert r.json()["status"] == "dismissed"
    assert r.json()["counts"]["dismissed"] == 3
