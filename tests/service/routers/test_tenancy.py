"""Tenancy (issue 13, finding 4): jobs and batches belong to the API key that made them."""

from __future__ import annotations

import pytest

from ..conftest import SQUARE, ClientFactory, assert_problem, wait_for

pytestmark = pytest.mark.anyio

A = {"X-API-Key": "key-a"}
B = {"Authorization": "Bearer key-b"}
INPUTS = {"boundary": SQUARE, "size": 0.5, "smoothing": {"method": "none"}}


async def test_another_keys_jobs_and_batches_are_not_there(make_client: ClientFactory) -> None:
    client = await make_client(api_keys="key-a,key-b")
    r = await client.post("/processes/mesh/execution", json={"inputs": INPUTS}, headers=A)
    assert r.status_code == 201, r.text
    job_id = r.json()["jobID"]
    client.headers.update(A)
    assert (await wait_for(client, job_id))["status"] == "successful"
    del client.headers["X-API-Key"]

    for path in (f"/jobs/{job_id}", f"/jobs/{job_id}/results"):
        assert_problem(await client.get(path, headers=B), 404, "no-such-job")
    assert_problem(await client.delete(f"/jobs/{job_id}", headers=B), 404, "no-such-job")
    assert (await client.get("/jobs", headers=B)).json()["numberMatched"] == 0
    mine = (await client.get("/jobs", headers=A)).json()
    assert [j["jobID"] for j in mine["jobs"]] == [job_id]
    assert (await client.get(f"/jobs/{job_id}/results", headers=A)).status_code == 200

    body = {"type": "FeatureCollection", "features": [{"type": "Feature", "geometry": SQUARE}]}
    body["inputs"] = {"size": 0.5, "smoothing": {"method": "none"}}
    r = await client.post("/batches", json=body, headers=A)
    assert r.status_code == 201, r.text
    batch_id = r.json()["batchID"]
    assert_problem(await client.get(f"/batches/{batch_id}", headers=B), 404, "no-such-batch")
    assert_problem(await client.delete(f"/batches/{batch_id}", headers=B), 404, "no-such-batch")
    assert (await client.get(f"/batches/{batch_id}", headers=A)).status_code == 200


async def test_idempotency_keys_are_each_clients_own(make_client: ClientFactory) -> None:
    client = await make_client(api_keys="key-a,key-b")
    same = {"Idempotency-Key": "order-1"}
    a = await client.post(
        "/processes/mesh/execution", json={"inputs": INPUTS}, headers={**A, **same}
    )
    other = {**INPUTS, "size": 0.25}
    b = await client.post(
        "/processes/mesh/execution", json={"inputs": other}, headers={**B, **same}
    )
    assert (a.status_code, b.status_code) == (201, 201), b.text  # no conflict across clients
    assert a.json()["jobID"] != b.json()["jobID"]
    assert "Idempotent-Replayed" not in b.headers
    again = await client.post(
        "/processes/mesh/execution", json={"inputs": INPUTS}, headers={**A, **same}
    )
    assert again.json()["jobID"] == a.json()["jobID"]
    conflict = await client.post(
        "/processes/mesh/execution", json={"inputs": other}, headers={**A, **same}
    )
    doc = assert_problem(conflict, 422, "idempotency-conflict")
    assert b.json()["jobID"] not in doc["detail"]  # never names another client's job


async def test_metrics_can_require_a_key(make_client: ClientFactory) -> None:
    open_metrics = await make_client(api_keys="key-a")
    assert (await open_metrics.get("/metrics")).status_code == 200
    closed = await make_client(api_keys="key-a", metrics_require_key=True)
    assert_problem(await closed.get("/metrics"), 401)
    assert_problem(await closed.get("/metrics", headers={"X-API-Key": "nope"}), 403)
    r = await closed.get("/metrics", headers=A)
    assert r.status_code == 200
    assert "evomesh_" in r.text


async def test_one_key_cannot_fill_the_queue(make_client: ClientFactory) -> None:
    client = await make_client(api_keys="key-a,key-b", max_queued_per_key=1, workers=1)
    url = "/processes/sleep/execution"
    running = await client.post(url, json={"inputs": {"seconds": 30}}, headers=A)
    client.headers.update(A)
    await wait_for(client, running.json()["jobID"], {"running"})
    del client.headers["X-API-Key"]
    assert (await client.post(url, json={"inputs": {"seconds": 0}}, headers=A)).status_code == 201
    r = await client.post(url, json={"inputs": {"seconds": 0}}, headers=A)
    doc = assert_problem(r, 429, "queue-full")
    assert r.headers["Retry-After"]
    assert doc["limit"] == 1
    other = await client.post(url, json={"inputs": {"seconds": 0}}, headers=B)
    assert other.status_code == 201, other.text  # another client still gets in
    await client.delete(f"/jobs/{running.json()['jobID']}", headers=A)
