"""OGC synchronous execution: ``Prefer`` (RFC 7240), ``response`` and ``outputs``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import httpx
import meshio
import pytest

from .conftest import SQUARE, assert_problem, wait_for

pytestmark = pytest.mark.anyio

MESH = {"boundary": SQUARE, "size": 0.25, "smoothing": {"method": "none"}}


async def _execute(
    client: httpx.AsyncClient, body: dict[str, Any], prefer: str | None = None
) -> httpx.Response:
    headers = {"Prefer": prefer} if prefer else {}
    return await client.post("/processes/mesh/execution", json=body, headers=headers)


async def test_sync_execute_is_offered(client: httpx.AsyncClient) -> None:
    described = (await client.get("/processes/mesh")).json()
    assert "sync-execute" in described["jobControlOptions"]
    listed = (await client.get("/processes")).json()["processes"]
    assert all("sync-execute" in p["jobControlOptions"] for p in listed)


async def test_no_prefer_is_async_and_applies_nothing(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"inputs": MESH})
    assert r.status_code == 201, r.text
    assert "preference-applied" not in r.headers
    assert r.json()["status"] == "accepted"


async def test_respond_async_is_applied(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"inputs": MESH}, prefer="respond-async")
    assert r.status_code == 201, r.text
    assert r.headers["preference-applied"] == "respond-async"


async def test_wait_answers_the_document_of_outputs(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"inputs": MESH, "response": "document"}, prefer="wait=60")
    assert r.status_code == 200, r.text
    assert r.headers["preference-applied"] == "wait=60"
    assert r.headers["location"].startswith("http://testserver/jobs/")
    doc = r.json()
    assert set(doc) == {"mesh"}
    assert len(doc["mesh"]["triangles"]) > 0
    # the job is kept: its results are the same mesh
    job_id = r.headers["location"].rsplit("/", 1)[1]
    assert (await client.get(f"/jobs/{job_id}/results")).json() == doc["mesh"]


async def test_wait_is_capped_by_the_setting(make_client: Any) -> None:
    client = await make_client(max_sync_wait=5.0)
    r = await _execute(client, {"inputs": MESH}, prefer="wait=3600")
    assert r.headers["preference-applied"] == "wait=5"


async def test_raw_response_in_the_asked_format(client: httpx.AsyncClient) -> None:
    body = {
        "inputs": MESH,
        "response": "raw",
        "outputs": {"mesh": {"format": {"mediaType": "application/geo+json"}}},
    }
    r = await _execute(client, body, prefer="wait=60")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"].startswith("application/geo+json")
    assert r.json()["type"] == "FeatureCollection"


async def test_raw_response_default_is_the_mesh_document(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"inputs": MESH, "response": "raw"}, prefer="wait=60")
    assert r.status_code == 200, r.text
    assert "triangles" in r.json()


async def test_raw_vtu_reads_back(client: httpx.AsyncClient, tmp_path: Path) -> None:
    body = {
        "inputs": MESH,
        "response": "raw",
        "outputs": {"mesh": {"format": {"mediaType": "application/xml"}}},  # vtu's
    }
    r = await _execute(client, body, prefer="wait=60")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"].startswith("application/xml")
    path = tmp_path / "mesh.vtu"
    path.write_bytes(r.content)
    mesh = meshio.read(path)
    assert len(mesh.points) > 0


async def test_unknown_output_id_is_a_400(client: httpx.AsyncClient) -> None:
    r = await _execute(client, {"inputs": MESH, "outputs": {"nope": {}}})
    assert_problem(r, 400, "invalid-parameter")
    assert "nope" in r.json()["detail"]


async def test_unknown_output_media_type_is_a_400(client: httpx.AsyncClient) -> None:
    body = {"inputs": MESH, "outputs": {"mesh": {"format": {"mediaType": "text/x-nope"}}}}
    assert_problem(await _execute(client, body), 400, "invalid-parameter")


async def test_wait_running_out_answers_the_job(client: httpx.AsyncClient) -> None:
    r = await client.post(
        "/processes/sleep/execution",
        json={"inputs": {"seconds": 30}},
        headers={"Prefer": "respond-async, wait=1"},
    )
    assert r.status_code == 201, r.text
    assert r.headers["preference-applied"] == "wait=1"
    assert r.json()["status"] in {"accepted", "running"}
    await client.delete(f"/jobs/{r.json()['jobID']}")


async def test_failed_job_within_the_wait_answers_its_status(client: httpx.AsyncClient) -> None:
    r = await client.post(
        "/processes/fail/execution", json={"inputs": {}}, headers={"Prefer": "wait=60"}
    )
    assert r.status_code == 201, r.text
    assert r.json()["status"] == "failed"
    assert (await wait_for(client, r.json()["jobID"]))["status"] == "failed"
