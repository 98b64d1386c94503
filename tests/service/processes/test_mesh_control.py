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

from ..conftest import SQUARE, ClientFactory, assert_problem, submit, wait_for

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
    # A capped estimate only says "over the cap": here the plain-size area bound already passes
    # it, so the engine answers that bound without counting (tests/engine/test_estimate.py counts
    # the field evaluations: none).
    assert capped > 1000
    assert capped <= 1.1 * 1.0 / (np.sqrt(3) / 4 * 1e-4**2)


async def test_admission_passes_the_triangle_limit_as_the_cap(
    limited: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    caps: list[int | None] = []
    estimate = engine.estimate_triangles

    def spy(*args: Any, cap: int | None = None, **kwargs: Any) -> int:
        caps.append(cap)
        return estimate(*args, cap=cap, **kwargs)

    monkeypatch.setattr(engine, "estimate_triangles", spy)
    # The square's area at the size is under the cap (that alone is refused before the size
    # field, see engine.estimate.refuse_by_area); the refinement takes the estimate over it.
    point = {"geometry": {"type": "Point", "coordinates": [0.5, 0.5]}, "size": 1e-4}
    inputs = {"boundary": SQUARE, "size": 0.05, "refinements": [point], "smoothing": NONE}
    r = await _execute(limited, inputs)
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


async def _result(client: httpx.AsyncClient, inputs: dict[str, Any]) -> dict[str, Any]:
    job = await submit(client, "mesh", inputs)
    status = await wait_for(client, job["jobID"])
    assert status["status"] == "successful", status.get("message")
    doc: dict[str, Any] = (await client.get(f"/jobs/{job['jobID']}/results")).json()
    return doc


async def test_a_refinement_makes_the_mesh_finer_near_it(client: httpx.AsyncClient) -> None:
    point = {"type": "Point", "coordinates": [0.5, 0.5]}
    plain = await _result(client, {"boundary": SQUARE, "size": 0.2, "smoothing": NONE})
    refined = await _result(
        client,
        {
            "boundary": SQUARE,
            "size": 0.2,
            "smoothing": NONE,
            "refinements": [{"geometry": point, "size": 0.02}],
        },
    )
    assert len(refined["triangles"]) > 3 * len(plain["triangles"])
    pts = np.asarray(refined["points"])
    near = np.hypot(*(pts - 0.5).T) < 0.03
    assert near.sum() >= 5  # nodes about 0.02 apart around the point


async def test_bad_refinements_are_located_422s(limited: httpx.AsyncClient) -> None:
    base = {"boundary": SQUARE, "size": 0.2, "smoothing": NONE}
    bad = [
        {"geometry": {"type": "Point", "coordinates": [0.5, 0.5]}, "size": 0.1},
        {"geometry": {"type": "Nowhere", "coordinates": []}, "size": 0.1},
    ]
    r = await _execute(limited, {**base, "refinements": bad})
    assert_problem(r, 422, "invalid-input", "/inputs/refinements/1")
    long = [[i / 6000, 0.5] for i in range(6000)]
    r = await _execute(
        limited,
        {
            **base,
            "refinements": [{"geometry": {"type": "LineString", "coordinates": long}, "size": 0.1}],
        },
    )
    assert_problem(r, 422, "limit-exceeded", "/inputs/refinements/0")
    r = await _execute(limited, {**base, "refinements": [bad[0]] * 1001})
    assert r.status_code == 422


DAM = {"type": "LineString", "coordinates": [[0.2, 0.3], [0.8, 0.6]]}


async def test_constraint_vertices_count_against_the_vertex_limit(
    limited: httpx.AsyncClient,
) -> None:
    # Counted with the boundary's and the refinements' (5,000 in all here); before, a
    # constraint had no limit but the body's size, a million vertices.
    point = {"geometry": {"type": "Point", "coordinates": [0.5, 0.5]}, "size": 0.1}
    fine = {"type": "LineString", "coordinates": [[0.1 + 0.8 * i / 4990, 0.5] for i in range(4990)]}
    over = {"type": "LineString", "coordinates": [[0.1 + 0.8 * i / 4996, 0.3] for i in range(4996)]}
    base = {"boundary": SQUARE, "size": 0.2, "smoothing": NONE, "refinements": [point]}
    features = [{"type": "Feature", "properties": {}, "geometry": g} for g in (DAM, over)]
    constraints = {"type": "FeatureCollection", "features": features}
    r = await _execute(limited, {**base, "constraints": constraints})
    doc = assert_problem(r, 422, "limit-exceeded", "/inputs/constraints/features/1/geometry")
    assert "constraints' vertices" in doc["detail"]
    # 4 boundary + 1 refinement + 4,990: within the limit, so the job is accepted.
    r = await _execute(limited, {**base, "constraints": fine})
    assert r.status_code == 201


async def test_constraints_become_tagged_mesh_edges_and_nodes(client: httpx.AsyncClient) -> None:
    constraints = {
        "type": "FeatureCollection",
        "features": [
            {"type": "Feature", "properties": {"name": "dam"}, "geometry": DAM},
            {
                "type": "Feature",
                "properties": {},
                "geometry": {"type": "Point", "coordinates": [0.7, 0.2]},
            },
        ],
    }
    doc = await _result(
        client,
        {
            "boundary": SQUARE,
            "size": 0.1,
            "smoothing": {"method": "laplacian"},
            "constraints": constraints,
        },
    )
    assert "dam" in doc["tags"]
    pts = np.asarray(doc["points"])
    dam = np.asarray(doc["lines"])[np.asarray(doc["line_data"]["tag"]) == doc["tags"]["dam"]]
    ends = pts[dam]  # every dam edge lies on the line y = 0.3 + 0.5 (x - 0.2)
    assert np.allclose(ends[..., 1], 0.3 + 0.5 * (ends[..., 0] - 0.2), atol=1e-9)
    assert np.isclose(np.hypot(*(ends[:, 1] - ends[:, 0]).T).sum(), np.hypot(0.6, 0.3))
    assert np.min(np.hypot(*(pts - [0.7, 0.2]).T)) < 1e-12  # the point is a node
    fixed = np.asarray(doc["point_data"]["fixed"], dtype=bool)
    assert fixed[np.unique(dam)].all()
    # The smoother moved nodes, and "boundary" still marks every node it never moves.
    assert doc["point_data"]["boundary"] == doc["point_data"]["fixed"]


async def test_a_constraint_outside_the_region_is_a_located_422(client: httpx.AsyncClient) -> None:
    out = {"type": "LineString", "coordinates": [[0.5, 0.5], [1.5, 0.5]]}
    fc = {
        "type": "FeatureCollection",
        "features": [{"type": "Feature", "properties": None, "geometry": out}],
    }
    r = await _execute(
        client, {"boundary": SQUARE, "size": 0.1, "smoothing": NONE, "constraints": fc}
    )
    doc = assert_problem(r, 422, "invalid-input", "/inputs/constraints/features/0/geometry")
    assert "leaves the region" in doc["detail"]
    r = await _execute(
        client, {"boundary": SQUARE, "size": 0.1, "smoothing": NONE, "constraints": SQUARE}
    )
    assert_problem(r, 422, "invalid-input", "/inputs/constraints")


def _pair(h_right: float | None, shift: float = 1.0) -> dict[str, Any]:
    left = [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]
    right = [[shift, 0], [shift + 1, 0], [shift + 1, 1], [shift, 1], [shift, 0]]
    props: dict[str, Any] = {"name": "b"} if h_right is None else {"name": "b", "h": h_right}
    return {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "properties": {"name": "a"},
                "geometry": {"type": "Polygon", "coordinates": [left]},
            },
            {
                "type": "Feature",
                "properties": props,
                "geometry": {"type": "Polygon", "coordinates": [right]},
            },
        ],
    }


def test_admission_estimates_subdomains_at_their_own_sizes() -> None:
    from service.processes import PROCESSES, inputs_at
    from service.settings import Settings

    def estimate(boundary: dict[str, Any]) -> int:
        model = PROCESSES["mesh"].inputs_model.model_validate(
            {"boundary": boundary, "size": 0.25, "smoothing": NONE}
        )
        settings = Settings(_env_file=None)  # type: ignore[call-arg]
        return PROCESSES["mesh"].prepare(model, settings, inputs_at("/inputs")).triangles

    assert estimate(_pair(0.05)) > 5 * estimate(_pair(None))


async def test_polygons_sharing_an_edge_are_meshed_as_subdomains(client: httpx.AsyncClient) -> None:
    doc = await _result(client, {"boundary": _pair(0.1), "size": 0.25, "smoothing": NONE})
    assert doc["regions"] == {"a": 1, "b": 2}
    assert {"a/outer", "b/outer", "a|b"} <= set(doc["tags"])
    region = np.asarray(doc["cell_data"]["region"])
    assert (region == 2).sum() > 1.5 * (region == 1).sum()  # b at its own, smaller h
    pts = np.asarray(doc["points"])
    shared = np.asarray(doc["lines"])[np.asarray(doc["line_data"]["tag"]) == doc["tags"]["a|b"]]
    assert np.allclose(pts[shared][..., 0], 1.0)


async def test_a_subdomain_whose_own_size_is_too_fine_is_a_422_at_its_h(
    client: httpx.AsyncClient,
) -> None:
    doc = assert_problem(
        await _execute(client, {"boundary": _pair(1e-9), "size": 0.25, "smoothing": NONE}),
        422,
        "limit-exceeded",
        "/inputs/boundary/features/1/properties/h",
    )
    assert doc["detail"].startswith("polygon 1: ")
    # The job's own size too fine (it sizes the polygon without an h): at /inputs/size.
    assert_problem(
        await _execute(client, {"boundary": _pair(None), "size": 1e-9, "smoothing": NONE}),
        422,
        pointer="/inputs/size",
    )


async def test_overlapping_polygons_stay_a_located_422(client: httpx.AsyncClient) -> None:
    r = await _execute(
        client, {"boundary": _pair(None, shift=0.5), "size": 0.25, "smoothing": NONE}
    )
    assert_problem(r, 422, pointer="/inputs/boundary/features/1")


async def test_a_refinement_grows_at_its_own_rate(client: httpx.AsyncClient) -> None:
    point = {"type": "Point", "coordinates": [0.5, 0.5]}
    base = {"boundary": SQUARE, "size": 0.2, "smoothing": NONE}
    counts = []
    for growth in (None, 1.05):
        refinement: dict[str, Any] = {"geometry": point, "size": 0.02}
        if growth is not None:
            refinement["growth"] = growth
        doc = await _result(client, {**base, "refinements": [refinement]})
        counts.append(len(doc["triangles"]))
    assert counts[1] > 2 * counts[0]  # growing at 1.05, not the job's 1.2: far more triangles
    r = await _execute(
        client, {**base, "refinements": [{"geometry": point, "size": 0.02, "growth": 1}]}
    )
    assert_problem(r, 422, pointer="/inputs/refinements/0/growth")


async def test_subdomains_take_constraints_in_one_job(client: httpx.AsyncClient) -> None:
    across = {"type": "LineString", "coordinates": [[0.5, 0.2], [1.5, 0.7]]}
    fc = {
        "type": "FeatureCollection",
        "features": [
            {"type": "Feature", "properties": {"name": "fault"}, "geometry": across},
            {
                "type": "Feature",
                "properties": {},
                "geometry": {"type": "Point", "coordinates": [0.3, 0.8]},
            },
        ],
    }
    doc = await _result(
        client,
        {
            "boundary": _pair(0.1),
            "size": 0.25,
            "smoothing": {"method": "laplacian"},
            "constraints": fc,
        },
    )
    assert doc["regions"] == {"a": 1, "b": 2}
    assert "fault" in doc["tags"]
    assert "a|b" in doc["tags"]
    pts = np.asarray(doc["points"])
    fault = np.asarray(doc["lines"])[np.asarray(doc["line_data"]["tag"]) == doc["tags"]["fault"]]
    ends = pts[fault]
    assert np.allclose(ends[..., 1], 0.2 + 0.5 * (ends[..., 0] - 0.5), atol=1e-9)
    assert np.isclose(np.hypot(*(ends[:, 1] - ends[:, 0]).T).sum(), np.hypot(1.0, 0.5))
    assert np.min(np.hypot(*(pts - [1.0, 0.45]).T)) < 1e-9  # noded on the interface
    assert np.min(np.hypot(*(pts - [0.3, 0.8]).T)) < 1e-12
    region = np.asarray(doc["cell_data"]["region"])
    centre = pts[np.asarray(doc["triangles"])].mean(axis=1)
    assert np.array_equal(region, np.where(centre[:, 0] < 1.0, 1, 2))


#: A lon/lat box about 11 km x 11 km at 60 N; control geometries in lon/lat, sizes in metres.
LONLAT = {
    "type": "Feature",
    "properties": {
        "name": "bay",
        "tags": [{"name": "shore", "from": 0, "to": 1}],
    },
    "geometry": {
        "type": "Polygon",
        "coordinates": [[[14.0, 60.0], [14.2, 60.0], [14.2, 60.1], [14.0, 60.1], [14.0, 60.0]]],
    },
}


async def test_mesh_control_with_lon_lat_input(client: httpx.AsyncClient) -> None:
    from pyproj import Geod

    dam = {"type": "LineString", "coordinates": [[14.05, 60.03], [14.15, 60.07]]}
    well = {"type": "Point", "coordinates": [14.1, 60.02]}
    doc = await _result(
        client,
        {
            "boundary": LONLAT,
            "crs": "EPSG:4326",
            "size": 1500,
            "smoothing": {"method": "laplacian"},
            "refinements": [{"geometry": well, "size": 150, "growth": 1.3}],
            "constraints": {
                "type": "FeatureCollection",
                "features": [{"type": "Feature", "properties": {"name": "dam"}, "geometry": dam}],
            },
        },
    )
    pts = np.asarray(doc["points"])  # back in lon/lat
    assert pts[:, 0].min() >= 14.0 - 1e-7
    assert pts[:, 0].max() <= 14.2 + 1e-7
    geod = Geod(ellps="WGS84")
    edges = np.asarray(doc["lines"])[np.asarray(doc["line_data"]["tag"]) == doc["tags"]["dam"]]
    a, b = pts[edges[:, 0]], pts[edges[:, 1]]
    metres = geod.inv(a[:, 0], a[:, 1], b[:, 0], b[:, 1])[2]
    whole = geod.inv(14.05, 60.03, 14.15, 60.07)[2]
    assert abs(metres.sum() - whole) < 1e-3 * whole  # the dam, every piece of it, in lon/lat
    assert metres.max() < 1.3 * 1500
    # Near the well the edges are about 150 m (refinement in metres), far away about 1500.
    tri = np.asarray(doc["triangles"])
    c = pts[tri].mean(axis=1)
    d = geod.inv(c[:, 0], c[:, 1], np.full(len(c), 14.1), np.full(len(c), 60.02))[2]
    side = geod.inv(pts[tri[:, 0], 0], pts[tri[:, 0], 1], pts[tri[:, 1], 0], pts[tri[:, 1], 1])[2]
    assert np.median(side[d < 200]) < 300
    assert np.median(side[d > 4000]) > 900
    # The named run from vertex 0 to 1 (the southern edge) is tagged along its whole length.
    shore = np.asarray(doc["lines"])[np.asarray(doc["line_data"]["tag"]) == doc["tags"]["shore"]]
    assert np.allclose(pts[shore][..., 1], 60.0, atol=1e-9)
    south = geod.inv(
        pts[shore][:, 0, 0], pts[shore][:, 0, 1], pts[shore][:, 1, 0], pts[shore][:, 1, 1]
    )[2]
    assert abs(south.sum() - geod.inv(14.0, 60.0, 14.2, 60.0)[2]) < 1.0


async def test_lon_lat_subdomains_with_a_constraint(client: httpx.AsyncClient) -> None:
    west = [[14.0, 60.0], [14.1, 60.0], [14.1, 60.1], [14.0, 60.1], [14.0, 60.0]]
    east = [[14.1, 60.0], [14.2, 60.0], [14.2, 60.1], [14.1, 60.1], [14.1, 60.0]]
    fc = {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "properties": {"name": "w"},
                "geometry": {"type": "Polygon", "coordinates": [west]},
            },
            {
                "type": "Feature",
                "properties": {"name": "e", "h": 700},
                "geometry": {"type": "Polygon", "coordinates": [east]},
            },
        ],
    }
    line = {"type": "LineString", "coordinates": [[14.05, 60.05], [14.15, 60.05]]}
    doc = await _result(
        client,
        {"boundary": fc, "crs": "EPSG:4326", "size": 1500, "smoothing": NONE, "constraints": line},
    )
    assert doc["regions"] == {"w": 1, "e": 2}
    assert doc["crs"]["geographic"] is True
    pts = np.asarray(doc["points"])
    region = np.asarray(doc["cell_data"]["region"])
    centre = pts[np.asarray(doc["triangles"])].mean(axis=1)
    assert np.array_equal(region, np.where(centre[:, 0] < 14.1, 1, 2))
    assert (region == 2).sum() > 1.5 * (region == 1).sum()  # e at its own 700 m
    tag = doc["tags"]["constraint-0"]
    edges = np.asarray(doc["lines"])[np.asarray(doc["line_data"]["tag"]) == tag]
    assert np.all(pts[edges][..., 0] >= 14.05 - 1e-9)
    assert np.min(np.hypot(*(pts - [14.1, 60.05]).T)) < 1e-6


def _digitised_duct() -> tuple[dict[str, Any], np.ndarray]:
    """A 100 x 60 rectangle traced every 0.3 with 0.05 of noise; a run names its western side
    from its corner (0, 60) down to a vertex half way."""
    rng = np.random.default_rng(11)
    corners = np.array([[0, 0], [100, 0], [100, 60], [0, 60]], dtype=float)
    sides = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        n = int(np.hypot(*(b - a)) / 0.3)
        side = a + (np.arange(n) / n)[:, None] * (b - a)
        side[1:] += rng.uniform(-0.05, 0.05, (n - 1, 2))
        sides.append(side)
    ring = np.concatenate(sides)
    west = len(ring) - len(sides[-1])  # the vertex at (0, 60)
    half = west + len(sides[-1]) // 2
    feature = {
        "type": "Feature",
        "properties": {"name": "duct", "tags": [{"name": "inlet", "from": west, "to": half}]},
        "geometry": {"type": "Polygon", "coordinates": [[*ring.tolist(), ring[0].tolist()]]},
    }
    return feature, ring[west : half + 1]


@pytest.mark.parametrize("constrained", [False, True])
async def test_named_runs_keep_working_with_resample(
    client: httpx.AsyncClient, constrained: bool
) -> None:
    feature, run = _digitised_duct()
    inputs: dict[str, Any] = {"boundary": feature, "size": 10, "resample": True, "smoothing": NONE}
    if constrained:  # the constraints path resamples the rings itself
        line = {"type": "LineString", "coordinates": [[20.0, 20.0], [50.0, 40.0]]}
        inputs["constraints"] = line
    doc = await _result(client, inputs)
    assert len(doc["triangles"]) < 300  # resampled: not the ~1,000 digitised vertices kept
    pts = np.asarray(doc["points"])
    inlet = np.asarray(doc["lines"])[np.asarray(doc["line_data"]["tag"]) == doc["tags"]["inlet"]]
    ends = pts[inlet]
    # The run's end vertices stay, and its edges cover it (within the resampling tolerance).
    assert np.hypot(*(pts - run[0]).T).min() < 1e-9
    assert np.hypot(*(pts - run[-1]).T).min() < 1e-9
    assert abs(np.hypot(*(ends[:, 1] - ends[:, 0]).T).sum() - (run[0, 1] - run[-1, 1])) < 0.1
    assert np.all(np.abs(ends[..., 0]) <= 1.0)  # on the western side only
    assert doc["summary"]["smoothed"]["boundary"]["max_deviation"] <= 1.0


async def test_the_process_description_offers_a_refinement_growth(
    client: httpx.AsyncClient,
) -> None:
    import json

    described = (await client.get("/processes/mesh")).json()
    text = json.dumps(described["inputs"]["refinements"])
    assert "growth" in text
    assert "away from the geometry; default the job's" in text


def _traced(a: list[float], b: list[float], rng: np.random.Generator) -> np.ndarray:
    """``a`` to ``b`` (``b`` left out) traced every 0.3 with 0.05 of noise; ``a`` exact."""
    a_, b_ = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = int(np.hypot(*(b_ - a_)) / 0.3)
    side = a_ + (np.arange(n) / n)[:, None] * (b_ - a_)
    side[1:] += rng.uniform(-0.05, 0.05, (n - 1, 2))
    return side


async def test_digitised_subdomains_are_resampled_sharing_their_interface(
    client: httpx.AsyncClient,
) -> None:
    """Two materials sharing a digitised interface, with a named run on a digitised side:
    with ``resample`` the interface is thinned once (one chain both regions share), the run's
    ends stay vertices, and the result reports the deviation and the pipeline's timings."""
    rng = np.random.default_rng(5)
    shared = _traced([50, 0], [50, 60], rng)  # up the interface
    west = _traced([0, 60], [0, 0], rng)
    left = np.concatenate([[[0.0, 0.0]], shared, [[50.0, 60.0]], west])
    right = np.concatenate([[[50.0, 0.0], [100, 0], [100, 60]], shared[::-1][:-1]])
    start = 2 + len(shared)  # (0, 60) in left
    half = start + len(west) // 2
    run = [{"name": "inlet", "from": start, "to": half}]

    def feature(name: str, ring: np.ndarray, **props: Any) -> dict[str, Any]:
        coords = [[*ring.tolist(), ring[0].tolist()]]
        geometry = {"type": "Polygon", "coordinates": coords}
        return {"type": "Feature", "properties": {"name": name, **props}, "geometry": geometry}

    boundary = {
        "type": "FeatureCollection",
        "features": [feature("a", left, tags=run), feature("b", right, h=5)],
    }
    inputs = {"boundary": boundary, "size": 10, "resample": True, "smoothing": NONE}
    doc = await _result(client, inputs)
    assert len(doc["triangles"]) < 1500  # resampled: not the ~400 digitised vertices kept
    report = doc["summary"]["smoothed"]["boundary"]
    assert report["vertices_after"] < report["vertices_before"] / 4
    assert report["max_deviation"] <= 0.5  # a tenth of the smaller size
    assert set(doc["summary"]["timings"]) == {"boundary", "mesh", "swap", "smooth", "total"}
    pts, lines = np.asarray(doc["points"]), np.asarray(doc["lines"])
    tag = np.asarray(doc["line_data"]["tag"])
    interface = pts[lines[tag == doc["tags"]["a|b"]]]
    assert np.all(np.abs(interface[..., 0] - 50) <= 0.5)
    length = np.hypot(*(interface[:, 1] - interface[:, 0]).T).sum()
    assert abs(length - 60) < 1.0  # one chain from bottom to top
    for end in (left[start], left[half]):
        assert np.hypot(*(pts - end).T).min() < 1e-9
    inlet = pts[lines[tag == doc["tags"]["inlet"]]]
    assert np.all(np.abs(inlet[..., 0]) <= 0.5)
