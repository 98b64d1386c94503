"""A region the engine refuses is a typed service error pointing into the input.

The engine's :class:`engine.InvalidBoundary` is wrapped (``LocatedInvalidBoundary``), never
annotated; the API's 422 and the CLI's line are what they were when it was annotated.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import httpx
import pytest

from engine import InvalidBoundary
from service.cli import main
from service.geojson import BoundaryInputError, LocatedInvalidBoundary, parse_region

from .conftest import assert_problem

SQUARE = [[0, 0], [4, 0], [4, 4], [0, 4], [0, 0]]
BOWTIE = [[0, 0], [2, 0], [2, 1], [1, 1], [1.5, -0.5], [0, 1], [0, 0]]
FEW = [[0, 0], [1, 0], [0, 0]]
HOLE_OUTSIDE = [[10, 10], [11, 10], [11, 11], [10, 10]]

CROSSES = "part 0 ring 0 (outer) intersects itself at (1.33333, 0) near vertex 0"
FEW_VERTICES = "part 0 ring 0 (outer) has fewer than 3 distinct vertices"
OUTSIDE = "part 0 ring 1 (hole) lies outside the outer ring"

#: Bad rings: the boundary, the pointer relative to it, the detail, the location.
BAD: dict[str, tuple[Any, str, str, list[float] | None]] = {
    "self-intersection": (
        {"type": "Polygon", "coordinates": [BOWTIE]},
        "/coordinates/0/0",
        CROSSES,
        [1.33333333333333, 0.0],
    ),
    "too few vertices": (
        {"type": "Polygon", "coordinates": [FEW]},
        "/coordinates/0",
        FEW_VERTICES,
        None,
    ),
    "hole outside": (
        {"type": "Polygon", "coordinates": [SQUARE, HOLE_OUTSIDE]},
        "/coordinates/1/0",
        OUTSIDE,
        None,
    ),
    "second polygon of a MultiPolygon": (
        {"type": "MultiPolygon", "coordinates": [[SQUARE], [[[x + 10, y] for x, y in BOWTIE]]]},
        "/coordinates/1/0/0",
        "part 0 ring 0 (outer) intersects itself at (11.3333, 0) near vertex 0",
        [11.3333333333333, 0.0],
    ),
    "outer/holes hole outside": (
        {"outer": SQUARE[:-1], "holes": [HOLE_OUTSIDE]},
        "/holes/0/0",
        OUTSIDE,
        None,
    ),
}


def _feature(geometry: Any, **properties: Any) -> dict[str, Any]:
    return {"type": "Feature", "properties": properties, "geometry": geometry}


def test_the_engine_error_is_wrapped_not_annotated() -> None:
    with pytest.raises(LocatedInvalidBoundary) as info:
        parse_region({"type": "Polygon", "coordinates": [BOWTIE]}, pointer="/inputs/boundary")
    err = info.value
    assert isinstance(err, BoundaryInputError)
    assert (err.pointer, err.message, str(err)) == (
        "/inputs/boundary/coordinates/0/0",
        CROSSES,
        CROSSES,
    )
    assert isinstance(err.cause, InvalidBoundary)
    assert err.__cause__ is err.cause
    assert not hasattr(err.cause, "pointer")


def test_a_densified_ring_points_at_the_input_vertex_and_leaves_the_engine_numbering() -> None:
    ring = [[14, 60], [14.5, 60], [14.5, 60.3], [14.2, 60.3], [14.3, 59.8], [14, 60.3], [14, 60]]
    with pytest.raises(LocatedInvalidBoundary) as info:
        parse_region({"type": "Polygon", "coordinates": [ring]}, crs="EPSG:4326", densify=500.0)
    err = info.value
    assert err.pointer == "/coordinates/0/3"
    # The engine numbered the densified ring: its error (and message) keep that numbering.
    assert err.cause.vertex is not None
    assert err.cause.vertex > 3
    assert err.message == err.cause.message


@pytest.mark.anyio
@pytest.mark.parametrize("case", BAD)
async def test_single_and_feature_collection_answers(client: httpx.AsyncClient, case: str) -> None:
    boundary, pointer, detail, location = BAD[case]
    r = await client.post(
        "/processes/mesh/execution", json={"inputs": {"boundary": boundary, "size": 0.5}}
    )
    doc = assert_problem(r, 422, "invalid-boundary", "/inputs/boundary" + pointer)
    assert (doc["detail"], doc.get("location")) == (detail, location)
    if boundary.get("type") != "Polygon":
        return  # the same polygon as the second of a FeatureCollection's features
    shifted = _feature(boundary)
    good = _feature({"type": "Polygon", "coordinates": [[[x + 20, y] for x, y in SQUARE]]})
    collection = {"type": "FeatureCollection", "features": [good, shifted]}
    r = await client.post(
        "/processes/mesh/execution", json={"inputs": {"boundary": collection, "size": 0.5}}
    )
    where = "/inputs/boundary/features/1/geometry" + pointer
    doc = assert_problem(r, 422, "invalid-boundary", where)
    assert (doc["detail"], doc.get("location")) == (detail, location)


@pytest.mark.anyio
async def test_batch_answers(client: httpx.AsyncClient) -> None:
    good = _feature({"type": "Polygon", "coordinates": [SQUARE]}, h=0.5)
    none = {"smoothing": {"method": "none"}}
    for case in ("self-intersection", "too few vertices", "hole outside"):
        boundary, pointer, detail, location = BAD[case]
        body = {"type": "FeatureCollection", "features": [good, _feature(boundary, h=0.5)]}
        r = await client.post("/batches", json={**body, "inputs": none})
        doc = assert_problem(r, 422, "invalid-boundary", "/features/1/geometry" + pointer)
        assert (doc["detail"], doc.get("location")) == (detail, location)
    requests = [{"inputs": {"boundary": BAD["too few vertices"][0]}}]
    r = await client.post("/batches", json={"inputs": {**none, "size": 0.5}, "requests": requests})
    assert_problem(r, 422, "invalid-boundary", "/requests/0/inputs/boundary/coordinates/0")
    assert (await client.get("/jobs")).json()["numberMatched"] == 0


@pytest.mark.parametrize("case", BAD)
def test_the_cli_line(tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str) -> None:
    src = tmp_path / "bad.json"
    src.write_text(json.dumps(BAD[case][0]))
    args = ["mesh", str(src), "--size", "0.5", "--smooth", "none", "-o", str(tmp_path / "o.json")]
    assert main(args) == 2
    assert capsys.readouterr().err == f"evomesh: error: {BAD[case][2]}\n"
