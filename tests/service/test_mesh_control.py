"""Mesh control through the API (issue 16): the admission estimate with its cap and limits,
boundary tags and regions in every mesh job."""

from __future__ import annotations

from typing import Any

import httpx
import numpy as np
import pytest

import engine
import engine.sizing
from service.processes import estimate_mesh

from .conftest import SQUARE, ClientFactory, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

NONE = {"method": "none"}


async def _execute(client: httpx.AsyncClient, inputs: dict[str, Any]) -> httpx.Response:
    return await client.post("/processes/mesh/execution", json={"inputs": inputs})


@pytest.fixture
async def limited(make_client: ClientFactory) -> httpx.AsyncClient:
    return await make_client(max_vertices=5000, max_triangles=1000)


def test_the_estimate_stops_counting_past_the_cap() -> None:
    square = engine.make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    sizing = engine.SizingParams(1e-4)  # about 2.3e8 triangles in all
    capped = estimate_mesh(square, sizing, cap=1000)
    assert 1000 < capped < 10**6


async def test_admission_passes_the_triangle_limit_as_the_cap(
    limited: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    caps: list[int | None] = []
    estimate = engine.estimate_triangles

    def spy(*args: Any, cap: int | None = None, **kwargs: Any) -> int:
        caps.append(cap)
        return estimate(*args, cap=cap, **kwargs)

    monkeypatch.setattr(engine, "estimate_triangles", spy)
    r = await _execute(limited, {"boundary": SQUARE, "size": 1e-4, "smoothing": NONE})
    doc = assert_problem(r, 422, "limit-exceeded", "/inputs/size")
    assert "triangles" in doc["detail"]
    assert caps == [1000]


async def test_too_many_gap_samples_is_a_422_at_size(
    limited: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(engine.sizing, "MAX_GAP_SAMPLES", 10)
    # A U whose slit is a hundredth of the size wide.
    u = [[0, 0], [3, 0], [3, 10], [1.505, 10], [1.505, 1], [1.495, 1], [1.495, 10], [0, 10]]
    comb = {"outer": u}
    r = await _execute(limited, {"boundary": comb, "size": 1.0, "smoothing": NONE})
    doc = assert_problem(r, 422, "limit-exceeded", "/inputs/size")
    assert "gaps" in doc["detail"]


async def test_a_dense_boundary_refusal_says_every_vertex_is_kept(
    limited: httpx.AsyncClient,
) -> None:
    t = np.linspace(0, 2 * np.pi, 3000, endpoint=False)
    circle = np.stack([np.cos(t), np.sin(t)], axis=1).tolist()
    r = await _execute(limited, {"boundary": {"outer": circle}, "size": 0.5, "smoothing": NONE})
    doc = assert_problem(r, 422, "limit-exceeded", "/inputs/size")
    assert "every boundary vertex is kept" in doc["detail"]
    assert "larger size or simplify the boundary" in doc["detail"]
    # A sparse boundary over the limit is refused without that hint.
    r = await _execute(limited, {"boundary": SQUARE, "size": 0.01, "smoothing": NONE})
    assert "every boundary vertex" not in assert_problem(r, 422, "limit-exceeded")["detail"]


DUCT = {
    "type": "Feature",
    "properties": {"name": "duct", "tags": [{"name": "inlet", "ring": 0, "from": 3, "to": 0}]},
    "geometry": {
        "type": "Polygon",
        "coordinates": [
            [[0, 0], [2, 0], [2, 1], [0, 1], [0, 0]],
            [[0.8, 0.4], [0.8, 0.6], [1.2, 0.6], [1.2, 0.4], [0.8, 0.4]],
        ],
    },
}


async def test_a_mesh_job_tags_its_boundaries_and_regions(
    client: httpx.AsyncClient, tmp_path: Any
) -> None:
    import meshio

    job = await submit(client, "mesh", {"boundary": DUCT, "size": 0.2, "smoothing": NONE})
    assert (await wait_for(client, job["jobID"]))["status"] == "successful"
    doc = (await client.get(f"/jobs/{job['jobID']}/results")).json()
    assert doc["tags"] == {"duct/outer": 1, "duct/hole-1": 2, "inlet": 3}
    assert doc["regions"] == {"duct": 1}
    assert set(doc["cell_data"]["region"]) == {1}
    assert len(doc["lines"]) == len(doc["line_data"]["tag"])
    pts = np.asarray(doc["points"])
    inlet = np.asarray(doc["lines"])[np.asarray(doc["line_data"]["tag"]) == 3]
    assert len(inlet) >= 5
    assert np.allclose(pts[inlet][..., 0], 0.0)
    r = await client.get(f"/jobs/{job['jobID']}/results", params={"f": "msh"})
    assert r.status_code == 200, r.text
    path = tmp_path / "duct.msh"
    path.write_bytes(r.content)
    groups = {k: v.tolist() for k, v in meshio.read(path).field_data.items()}
    assert groups == {"duct/outer": [1, 1], "duct/hole-1": [2, 1], "inlet": [3, 1], "duct": [1, 2]}


async def test_a_bad_tag_run_is_a_located_422(client: httpx.AsyncClient) -> None:
    bad = {**DUCT, "properties": {"tags": [{"name": "inlet", "ring": 2, "from": 0, "to": 1}]}}
    r = await _execute(client, {"boundary": bad, "size": 0.2, "smoothing": NONE})
    assert_problem(r, 422, pointer="/inputs/boundary/properties/tags/0/ring")


async def test_each_feature_of_a_collection_names_its_region(client: httpx.AsyncClient) -> None:
    left = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
    right = {"type": "Polygon", "coordinates": [[[2, 0], [3, 0], [3, 1], [2, 1], [2, 0]]]}
    runs = [{"name": "east", "from": 1, "to": 2}]
    fc = {
        "type": "FeatureCollection",
        "features": [
            {"type": "Feature", "properties": {"name": "a"}, "geometry": left},
            {"type": "Feature", "properties": {"name": "b", "tags": runs}, "geometry": right},
        ],
    }
    job = await submit(client, "mesh", {"boundary": fc, "size": 0.25, "smoothing": NONE})
    assert (await wait_for(client, job["jobID"]))["status"] == "successful"
    doc = (await client.get(f"/jobs/{job['jobID']}/results")).json()
    assert doc["regions"] == {"a": 1, "b": 2}
    assert set(doc["tags"]) == {"a/outer", "b/outer", "east"}
    pts = np.asarray(doc["points"])
    east = np.asarray(doc["lines"])[np.asarray(doc["line_data"]["tag"]) == doc["tags"]["east"]]
    assert np.allclose(pts[east][..., 0], 3.0)
