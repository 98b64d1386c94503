"""The OGC job flow: execution, status, results in every format, listing, dismissal."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import httpx
import meshio
import numpy as np
import pytest

import engine
from tests.conftest import load_case

from ..conftest import SQUARE, ClientFactory, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

NONE = {"method": "none"}


async def _mesh(client: httpx.AsyncClient, **inputs: Any) -> dict[str, Any]:
    inputs.setdefault("boundary", SQUARE)
    inputs.setdefault("size", 0.2)
    inputs.setdefault("smoothing", NONE)
    return await submit(client, "mesh", inputs)


async def _result(client: httpx.AsyncClient, job_id: str, f: str = "json") -> httpx.Response:
    r = await client.get(f"/jobs/{job_id}/results", params={"f": f})
    assert r.status_code == 200, r.text
    return r


async def test_execute_poll_and_fetch_a_valid_mesh(client: httpx.AsyncClient) -> None:
    case = load_case("l_shape")
    r = await client.post(
        "/processes/mesh/execution", json={"inputs": {"boundary": case, "smoothing": NONE}}
    )
    assert r.status_code == 201
    job = r.json()
    assert r.headers["location"] == f"http://testserver/jobs/{job['jobID']}"
    assert job["status"] == "accepted"
    assert (job["type"], job["processID"], job["progress"]) == ("process", "mesh", 0)
    assert isinstance(job["seed"], int)  # chosen and stored
    done = await wait_for(client, job["jobID"])
    assert done["status"] == "successful", done
    assert (done["progress"], done["attempts"]) == (100, 1)
    assert done["started"] is not None
    assert done["finished"] >= done["started"] >= done["created"]
    rels = {link["rel"] for link in done["links"]}
    assert "http://www.opengis.net/def/rel/ogc/1.0/results" in rels
    doc = (await _result(client, job["jobID"])).json()
    mesh = engine.validate_mesh(doc["points"], doc["triangles"])
    assert mesh.n_triangles == len(doc["cell_data"]["quality"])
    assert len(doc["point_data"]["fitness"]) == mesh.n_points
    assert {"initial", "swapped", "smoothed", "parameters", "timings"} <= set(doc["summary"])
    params = doc["summary"]["parameters"]
    assert params["seed"] == job["seed"]
    assert params["sizing"]["size"] == case["properties"]["h"]  # default from the Feature


async def test_results_in_every_format(client: httpx.AsyncClient) -> None:
    job = await _mesh(client)
    await wait_for(client, job["jobID"])
    doc = (await _result(client, job["jobID"])).json()
    n_tri, n_pts = len(doc["triangles"]), len(doc["points"])

    gj = await _result(client, job["jobID"], "geojson")
    assert gj.headers["content-type"].startswith("application/geo+json")
    fc = gj.json()
    assert fc["type"] == "FeatureCollection"
    # The triangles, then the tagged boundary lines (every mesh job is tagged).
    kinds = [f["geometry"]["type"] for f in fc["features"]]
    assert kinds.count("Polygon") == n_tri
    assert kinds.count("LineString") == len(doc["lines"])
    first = fc["features"][0]
    assert first["geometry"]["type"] == "Polygon"
    assert len(first["geometry"]["coordinates"][0]) == 4
    assert set(first["properties"]) >= {"quality", "radius_ratio", "min_angle", "max_angle"}
    assert first["properties"]["quality"] == doc["cell_data"]["quality"][0]

    for f, fmt in (("vtu", "vtu"), ("msh", "gmsh")):
        r = await _result(client, job["jobID"], f)
        assert f".{f}" in r.headers["content-disposition"]
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / f"m.{f}"
            path.write_bytes(r.content)
            m = meshio.read(path, file_format=fmt)
        assert len(m.points) == n_pts
        assert len(m.cells_dict["triangle"]) == n_tri
        assert np.allclose(m.point_data["fitness"], doc["point_data"]["fitness"])
        assert np.allclose(m.cell_data["quality"][0], doc["cell_data"]["quality"])

    r = await client.get(f"/jobs/{job['jobID']}/results", params={"f": "pdf"})
    assert_problem(r, 400, "invalid-parameter")


async def test_json_result_is_sent_compressed_when_the_client_accepts_it(
    client: httpx.AsyncClient,
) -> None:
    job = await _mesh(client)
    await wait_for(client, job["jobID"])
    url = f"/jobs/{job['jobID']}/results"
    req = client.build_request("GET", url, headers={"Accept-Encoding": "deflate"})
    r = await client.send(req, stream=True)
    raw = await r.aread()  # httpx decodes deflate
    assert r.headers["content-encoding"] == "deflate"
    assert json.loads(raw)["triangles"]
    r2 = await client.get(url, headers={"Accept-Encoding": "identity"})
    assert "content-encoding" not in r2.headers
    assert r2.json() == json.loads(raw)


async def test_same_seed_same_mesh_and_stored_seed_reruns(make_client: ClientFactory) -> None:
    client = await make_client(workers=2)
    case = load_case("plate_hole")
    a = await submit(client, "mesh", {"boundary": case, "smoothing": {**NONE, "seed": 7}})
    b = await submit(client, "mesh", {"boundary": case, "smoothing": {**NONE, "seed": 7}})
    c = await submit(client, "mesh", {"boundary": case, "smoothing": NONE})
    docs = []
    for job in (a, b, c):
        assert (await wait_for(client, job["jobID"]))["status"] == "successful"
        docs.append((await _result(client, job["jobID"])).json())
    assert a["seed"] == 7
    assert docs[0]["points"] == docs[1]["points"]
    assert docs[0]["triangles"] == docs[1]["triangles"]
    rerun = await submit(
        client, "mesh", {"boundary": case, "smoothing": {**NONE, "seed": c["seed"]}}
    )
    await wait_for(client, rerun["jobID"])
    again = (await _result(client, rerun["jobID"])).json()
    assert again["points"] == docs[2]["points"]


async def test_multi_part_feature_collection_is_one_region(client: httpx.AsyncClient) -> None:
    def square(x: float) -> dict[str, Any]:
        ring = [[x, 0], [x + 1, 0], [x + 1, 1], [x, 1], [x, 0]]
        return {
            "type": "Feature",
            "properties": {},
            "geometry": {"type": "Polygon", "coordinates": [ring]},
        }

    fc = {"type": "FeatureCollection", "features": [square(0), square(3)]}
    job = await _mesh(client, boundary=fc, size=0.25)
    assert (await wait_for(client, job["jobID"]))["status"] == "successful"
    doc = (await _result(client, job["jobID"])).json()
    xs = np.asarray(doc["points"])[:, 0]
    assert xs.min() == 0
    assert xs.max() == 4
    assert not np.any((xs > 1) & (xs < 3))  # nothing meshed between the parts
    jobs = (await client.get("/jobs")).json()
    assert jobs["numberMatched"] == 1


async def test_wgs84_region_comes_back_in_lon_lat(client: httpx.AsyncClient) -> None:
    lon, lat, d = 7.0, 46.0, 0.01  # ~1 km square
    ring = [[lon, lat], [lon + d, lat], [lon + d, lat + d], [lon, lat + d], [lon, lat]]
    boundary = {"type": "Polygon", "coordinates": [ring]}
    job = await _mesh(client, boundary=boundary, size=200.0, coordinates="wgs84")
    assert (await wait_for(client, job["jobID"]))["status"] == "successful"
    doc = (await _result(client, job["jobID"])).json()
    pts = np.asarray(doc["points"])
    assert doc["crs"]["input"] == "OGC:CRS84"
    assert doc["crs"]["mesh"] == "EPSG:32632"  # the region's UTM zone
    assert np.all((pts[:, 0] >= lon - 1e-9) & (pts[:, 0] <= lon + d + 1e-9))
    assert np.all((pts[:, 1] >= lat - 1e-9) & (pts[:, 1] <= lat + d + 1e-9))
    assert np.ptp(np.asarray(doc["projected"]["points"])[:, 0]) > 500  # metres


async def test_smooth_and_quality_processes(client: httpx.AsyncClient) -> None:
    poor = json.loads(Path("tests/data/poor/l_shape.poor.json").read_text())
    s = await submit(client, "smooth", {"mesh": poor, "smoothing": {**NONE, "seed": 3}})
    q = await submit(client, "quality", {"mesh": poor, "fitness": "angle"})
    for job in (s, q):
        assert (await wait_for(client, job["jobID"]))["status"] == "successful"
    smoothed = (await _result(client, s["jobID"])).json()
    engine.validate_mesh(smoothed["points"], smoothed["triangles"])
    assert smoothed["summary"]["parameters"]["seed"] == 3
    quality = (await _result(client, q["jobID"])).json()
    assert len(quality["cell_data"]["quality"]) == len(poor["triangles"])
    assert quality["summary"]["parameters"]["fitness"] == "angle"
    assert quality["summary"]["mesh"]["count"] == len(poor["triangles"])
    gj = (await _result(client, q["jobID"], "geojson")).json()
    assert len(gj["features"]) == len(poor["triangles"])


async def test_results_of_unfinished_failed_and_unknown_jobs(client: httpx.AsyncClient) -> None:
    sleeping = await submit(client, "sleep", {"seconds": 30})
    r = await client.get(f"/jobs/{sleeping['jobID']}/results")
    assert_problem(r, 404, "ogcapi-processes-1/1.0/result-not-ready")
    await client.delete(f"/jobs/{sleeping['jobID']}")
    assert_problem(await client.get(f"/jobs/{sleeping['jobID']}/results"), 410, "job-dismissed")
    failed = await submit(client, "fail", {})
    done = await wait_for(client, failed["jobID"])
    assert done["status"] == "failed"
    assert done["message"] == "bad input"
    assert_problem(await client.get(f"/jobs/{failed['jobID']}/results"), 409, "job-failed")
    for path in ("/jobs/nope", "/jobs/nope/results"):
        assert_problem(await client.get(path), 404, "ogcapi-processes-1/1.0/no-such-job")
    assert_problem(await client.delete("/jobs/nope"), 404, "/no-such-job")


async def test_progress_and_stage_while_running(client: httpx.AsyncClient) -> None:
    job = await submit(client, "sleep", {"seconds": 3})
    doc = await wait_for(client, job["jobID"], {"running"}, progress_over=10)
    assert doc["message"] == "sleeping"
    assert 10 < doc["progress"] < 100
    assert doc["started"] is not None
    assert doc["updated"] >= doc["started"]
    await client.delete(f"/jobs/{job['jobID']}")


async def test_dismiss_a_queued_job_it_never_runs(client: httpx.AsyncClient) -> None:
    busy = await submit(client, "sleep", {"seconds": 30})
    queued = await _mesh(client)
    await wait_for(client, busy["jobID"], {"running"})
    r = await client.delete(f"/jobs/{queued['jobID']}")
    assert r.status_code == 200
    assert r.json()["status"] == "dismissed"
    await client.delete(f"/jobs/{busy['jobID']}")
    follow = await _mesh(client)  # the worker is free again and runs the next job
    assert (await wait_for(client, follow["jobID"]))["status"] == "successful"
    doc = (await client.get(f"/jobs/{queued['jobID']}")).json()
    assert (doc["status"], doc.get("started"), doc["attempts"]) == ("dismissed", None, 0)


async def test_dismiss_a_running_job_stops_it(client: httpx.AsyncClient) -> None:
    job = await submit(client, "sleep", {"seconds": 60})
    await wait_for(client, job["jobID"], {"running"})
    r = await client.delete(f"/jobs/{job['jobID']}")
    assert r.json()["status"] == "dismissed"
    # The worker stops at its next check and takes the next job well before 60 s.
    follow = await _mesh(client)
    assert (await wait_for(client, follow["jobID"], timeout=20))["status"] == "successful"
    assert (await client.get(f"/jobs/{job['jobID']}")).json()["status"] == "dismissed"
    again = await client.delete(f"/jobs/{job['jobID']}")  # dismissing twice is harmless
    assert again.json()["status"] == "dismissed"


async def test_dismiss_a_successful_job_deletes_its_results(client: httpx.AsyncClient) -> None:
    job = await _mesh(client)
    await wait_for(client, job["jobID"])
    assert (await client.delete(f"/jobs/{job['jobID']}")).json()["status"] == "dismissed"
    assert_problem(await client.get(f"/jobs/{job['jobID']}/results"), 410)


async def test_job_list_filters_and_pages(client: httpx.AsyncClient) -> None:
    ids = [(await _mesh(client))["jobID"] for _ in range(5)]
    for job_id in ids:
        await wait_for(client, job_id)
    sleeping = await submit(client, "sleep", {"seconds": 30})
    await wait_for(client, sleeping["jobID"], {"running"})
    page = (await client.get("/jobs", params={"limit": 2})).json()
    assert page["numberMatched"] == 6
    assert [j["jobID"] for j in page["jobs"]] == [sleeping["jobID"], ids[4]]
    links = {link["rel"]: link["href"] for link in page["links"]}
    assert "prev" not in links
    nxt = (await client.get(links["next"])).json()
    assert [j["jobID"] for j in nxt["jobs"]] == [ids[3], ids[2]]
    nlinks = {link["rel"]: link["href"] for link in nxt["links"]}
    assert "offset=0" in nlinks["prev"]
    last = (await client.get("/jobs", params={"limit": 2, "offset": 4})).json()
    assert "next" not in {link["rel"] for link in last["links"]}
    running = (await client.get("/jobs", params={"status": "running"})).json()
    assert [j["jobID"] for j in running["jobs"]] == [sleeping["jobID"]]
    meshes = (
        await client.get("/jobs", params=[("processID", "mesh"), ("status", "successful")])
    ).json()
    assert meshes["numberMatched"] == 5
    assert_problem(await client.get("/jobs", params={"status": "sleeping"}), 422)
    assert_problem(await client.get("/jobs", params={"limit": 0}), 422)
    await client.delete(f"/jobs/{sleeping['jobID']}")


async def test_idempotency_key(client: httpx.AsyncClient) -> None:
    body = {"inputs": {"boundary": SQUARE, "size": 0.25, "smoothing": NONE}}
    h = {"Idempotency-Key": "order-42"}
    first = await client.post("/processes/mesh/execution", json=body, headers=h)
    again = await client.post("/processes/mesh/execution", json=body, headers=h)
    assert first.status_code == again.status_code == 201
    assert first.json()["jobID"] == again.json()["jobID"]
    assert first.json()["seed"] == again.json()["seed"]
    assert again.headers["idempotent-replayed"] == "true"
    assert again.headers["location"] == first.headers["location"]
    # The same JSON value written differently is the same request.
    text = json.dumps({"inputs": {"smoothing": NONE, "size": 0.25, "boundary": SQUARE}}, indent=2)
    third = await client.post(
        "/processes/mesh/execution",
        content=text,
        headers={**h, "Content-Type": "application/json"},
    )
    assert third.json()["jobID"] == first.json()["jobID"]
    other = {"inputs": {**body["inputs"], "size": 0.5}}
    r = await client.post("/processes/mesh/execution", json=other, headers=h)
    assert_problem(r, 422, "idempotency-conflict")
    fresh = await client.post(
        "/processes/mesh/execution", json=body, headers={"Idempotency-Key": "x"}
    )
    assert fresh.json()["jobID"] != first.json()["jobID"]
    assert (await client.get("/jobs")).json()["numberMatched"] == 2
