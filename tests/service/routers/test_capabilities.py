"""Landing page, conformance, process list and descriptions, OpenAPI, probes and metrics."""

from __future__ import annotations

import httpx
import pytest

import engine
from service.routers.landing import CONFORMANCE

from ..conftest import SQUARE, ClientFactory, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio


async def test_landing_page_links_the_api(client: httpx.AsyncClient) -> None:
    r = await client.get("/")
    assert r.status_code == 200
    rels = {link["rel"]: link["href"] for link in r.json()["links"]}
    assert rels["service-desc"] == "http://testserver/openapi.json"
    assert rels["http://www.opengis.net/def/rel/ogc/1.0/conformance"].endswith("/conformance")
    assert rels["http://www.opengis.net/def/rel/ogc/1.0/processes"].endswith("/processes")
    assert rels["http://www.opengis.net/def/rel/ogc/1.0/job-list"].endswith("/jobs")
    assert (await client.get("/openapi.json")).json()["paths"]["/jobs/{jobId}"]


async def test_conformance_lists_the_ogc_classes(client: httpx.AsyncClient) -> None:
    classes = (await client.get("/conformance")).json()["conformsTo"]
    assert classes == CONFORMANCE
    base = "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/"
    for name in ("core", "ogc-process-description", "json", "job-list", "dismiss"):
        assert base + name in classes


async def test_process_list_and_descriptions(client: httpx.AsyncClient) -> None:
    doc = (await client.get("/processes")).json()
    ids = [p["id"] for p in doc["processes"]]
    assert {"mesh", "smooth", "quality"} <= set(ids)
    for p in doc["processes"]:
        assert p["jobControlOptions"] == ["sync-execute", "async-execute", "dismiss"]
        assert any(link["rel"] == "self" for link in p["links"])
    mesh = (await client.get("/processes/mesh")).json()
    inputs = mesh["inputs"]
    assert set(inputs) >= {"boundary", "size", "growth", "swap", "smoothing", "coordinates"}
    assert inputs["boundary"]["minOccurs"] == 1
    assert inputs["size"]["minOccurs"] == 0
    smoothing = inputs["smoothing"]["schema"]
    assert "$ref" not in str(smoothing)  # definitions are inlined
    assert smoothing["properties"]["method"]["default"] == "ga"
    assert smoothing["properties"]["method"]["enum"] == sorted(engine.SMOOTHERS)
    assert smoothing["properties"]["population"]["default"] == 100
    assert "mesh" in mesh["outputs"]
    smooth = (await client.get("/processes/smooth")).json()
    assert smooth["inputs"]["mesh"]["schema"]["required"] == ["points", "triangles"]


async def test_unknown_process(client: httpx.AsyncClient) -> None:
    assert_problem(await client.get("/processes/nope"), 404, "/no-such-process")
    r = await client.post("/processes/nope/execution", json={"inputs": {}})
    assert_problem(r, 404, "/no-such-process")


async def test_openapi_documents_problems(client: httpx.AsyncClient) -> None:
    spec = (await client.get("/openapi.json")).json()
    op = spec["paths"]["/processes/mesh/execution"]["post"]
    assert "application/problem+json" in op["responses"]["422"]["content"]
    assert "Location" in op["responses"]["201"]["headers"]
    assert "ProblemDetails" in spec["components"]["schemas"]


async def test_health_ready_and_metrics(client: httpx.AsyncClient) -> None:
    assert (await client.get("/health")).json() == {"status": "ok"}
    ready = (await client.get("/ready")).json()
    assert ready["status"] == "ready"
    assert ready["workers"]["alive"] == 1
    job = await submit(
        client, "mesh", {"boundary": SQUARE, "size": 0.2, "smoothing": {"method": "none"}}
    )
    done = await wait_for(client, job["jobID"])
    assert done["status"] == "successful"
    text = (await client.get("/metrics")).text
    assert 'evomesh_jobs{status="successful"} 1.0' in text
    assert 'evomesh_jobs_submitted_total{process="mesh"} 1.0' in text
    assert "evomesh_queue_depth 0.0" in text
    assert 'evomesh_job_duration_seconds_count{process="mesh"} 1.0' in text
    produced = [
        line for line in text.splitlines() if line.startswith("evomesh_triangles_produced_total")
    ]
    assert float(produced[0].split()[1]) > 0


async def test_ready_fails_when_the_service_is_not_running(tmp_path: object) -> None:
    from service.app import create_app

    from ..conftest import make_settings

    app = create_app(make_settings(tmp_path))  # type: ignore[arg-type]
    transport = httpx.ASGITransport(app=app)
    async with httpx.AsyncClient(transport=transport, base_url="http://t") as c:
        assert_problem(await c.get("/ready"), 503)
        assert_problem(await c.get("/jobs"), 503)
        assert (await c.get("/health")).status_code == 200


async def test_api_keys(make_client: ClientFactory) -> None:
    client = await make_client(api_keys="k1,k2")
    assert (await client.get("/processes")).status_code == 200  # public
    assert_problem(await client.get("/jobs"), 401)
    assert (await client.get("/jobs")).headers["www-authenticate"] == "Bearer"
    assert_problem(await client.get("/jobs", headers={"X-API-Key": "bad"}), 403)
    body = {"inputs": {"boundary": SQUARE, "size": 0.5, "smoothing": {"method": "none"}}}
    assert_problem(await client.post("/processes/mesh/execution", json=body), 401)
    assert_problem(await client.post("/batches", json={"requests": [body]}), 401)
    assert (await client.get("/jobs", headers={"X-API-Key": "k2"})).status_code == 200
    r = await client.post(
        "/processes/mesh/execution", json=body, headers={"Authorization": "Bearer k1"}
    )
    assert r.status_code == 201


async def test_cors_when_origins_are_configured(make_client: ClientFactory) -> None:
    client = await make_client(cors_origins="http://viewer.test")
    r = await client.options(
        "/jobs",
        headers={"Origin": "http://viewer.test", "Access-Control-Request-Method": "GET"},
    )
    assert r.status_code == 200
    assert r.headers["access-control-allow-origin"] == "http://viewer.test"
    r = await client.get("/processes", headers={"Origin": "http://elsewhere.test"})
    assert "access-control-allow-origin" not in r.headers


async def test_unknown_routes_and_methods_are_problems(client: httpx.AsyncClient) -> None:
    assert_problem(await client.get("/nowhere"), 404)
    assert_problem(await client.put("/jobs"), 405)


async def test_an_untrusted_host_is_a_problem(make_client: ClientFactory) -> None:
    client = await make_client(trusted_hosts="testserver,*.example.org")
    for host in ("evil.example", "example.org.evil.example", "", "[::1"):
        r = await client.get("/health", headers={"Host": host})
        doc = assert_problem(r, 400, "untrusted-host")
        assert doc["instance"] == "/health"
        assert "evil" not in r.text
    r = await client.post("/processes/mesh/execution", json={}, headers={"Host": "x.evil"})
    assert_problem(r, 400, "untrusted-host")
    assert (await client.get("/health", headers={"Host": "api.example.org"})).status_code == 200
    assert (await client.get("/health")).status_code == 200
