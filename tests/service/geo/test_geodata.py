"""Geodata on the request path (issue 17): any CRS, lengths true on the ellipsoid, the
antimeridian, RFC 7946 output, 422s that point at the input, and the CLI's --crs and GIS files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pyogrio.raw
import pytest
import shapely
from numpy.typing import NDArray
from pyproj import Geod

from service.cli import main

from ..conftest import assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

NONE = {"method": "none"}
GEOD = Geod(ellps="WGS84")


def _box(lon0: float, lat0: float, dlon: float, dlat: float) -> dict[str, Any]:
    ring = [[lon0, lat0], [lon0 + dlon, lat0], [lon0 + dlon, lat0 + dlat], [lon0, lat0 + dlat]]
    return {"type": "Polygon", "coordinates": [[*ring, ring[0]]]}


def _edges(triangles: NDArray[np.int64]) -> NDArray[np.int64]:
    pairs = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(pairs, axis=0)


def geodesic_edge_lengths(doc: dict[str, Any]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Every edge's length on the WGS84 ellipsoid (metres) and its mid latitude."""
    pts = np.asarray(doc["points"], dtype=np.float64)
    e = _edges(np.asarray(doc["triangles"], dtype=np.int64))
    a, b = pts[e[:, 0]], pts[e[:, 1]]
    _, _, dist = GEOD.inv(a[:, 0], a[:, 1], b[:, 0], b[:, 1])
    return np.asarray(dist), 0.5 * (a[:, 1] + b[:, 1])


async def _meshed(client: httpx.AsyncClient, f: str = "json", **inputs: Any) -> dict[str, Any]:
    inputs.setdefault("smoothing", NONE)
    job = await submit(client, "mesh", inputs)
    status = await wait_for(client, job["jobID"], timeout=120)
    assert status["status"] == "successful", status
    r = await client.get(f"/jobs/{job['jobID']}/results", params={"f": f})
    assert r.status_code == 200, r.text
    doc: dict[str, Any] = r.json()
    return doc


async def test_lonlat_at_60n_has_true_edge_lengths_on_the_ellipsoid(
    client: httpx.AsyncClient,
) -> None:
    # A 10 x 10 degree box at 55-65 N (the case: 19.06 km south, 17.42 km north before).
    size = 60_000.0
    doc = await _meshed(client, boundary=_box(5.0, 55.0, 10.0, 10.0), size=size, crs="EPSG:4326")
    assert doc["crs"]["input"] == "EPSG:4326"
    assert doc["crs"]["geographic"] is True
    assert doc["crs"]["length_tolerance"] < 0.01
    lengths, lat = geodesic_edge_lengths(doc)
    south, north = lengths[lat < 58.0], lengths[lat > 62.0]
    assert abs(np.median(lengths) / size - 1.0) < 0.1, np.median(lengths)
    # The same size in the south and the north (the former plane's differed by 9%): the
    # difference left is the mesher's own scatter over a few hundred edges.
    assert abs(np.median(south) / np.median(north) - 1.0) < 0.06, (
        np.median(south),
        np.median(north),
    )
    # The plane's lengths are the ellipsoid's within the stated tolerance.
    plane = np.asarray(doc["projected"]["points"])
    e = _edges(np.asarray(doc["triangles"]))
    planar = np.hypot(*(plane[e[:, 0]] - plane[e[:, 1]]).T)
    tolerance = doc["crs"]["length_tolerance"]
    assert np.all(np.abs(planar / lengths - 1.0) <= tolerance + 1e-4)
    print(  # the figures the report quotes (pytest -s)
        f"edges {lengths.size}: median {np.median(lengths):.0f} m, mean {lengths.mean():.0f} m,"
        f" south median {np.median(south):.0f} m, north median {np.median(north):.0f} m,"
        f" plane/ellipsoid ratio {np.min(planar / lengths):.5f}..{np.max(planar / lengths):.5f},"
        f" tolerance {tolerance:.5f}"
    )


async def test_a_utm_region_is_meshed_in_its_own_coordinates(client: httpx.AsyncClient) -> None:
    x0, y0 = 500_000.0, 6_650_000.0
    doc = await _meshed(client, boundary=_box(x0, y0, 4000.0, 3000.0), size=500.0, crs="EPSG:32633")
    assert doc["crs"]["input"] == doc["crs"]["mesh"] == "EPSG:32633"
    assert "projected" not in doc  # the points are the plane's already
    pts = np.asarray(doc["points"])
    assert np.allclose(pts.min(axis=0), [x0, y0])
    assert np.allclose(pts.max(axis=0), [x0 + 4e3, y0 + 3e3])
    e = _edges(np.asarray(doc["triangles"]))
    assert abs(np.median(np.hypot(*(pts[e[:, 0]] - pts[e[:, 1]]).T)) / 500.0 - 1.0) < 0.15


def _ring_area(ring: list[list[float]]) -> float:
    xy = np.asarray(ring)
    return 0.5 * float(np.sum(xy[:-1, 0] * xy[1:, 1] - xy[1:, 0] * xy[:-1, 1]))


async def test_an_antimeridian_box_comes_back_in_range_and_as_rfc7946(
    client: httpx.AsyncClient,
) -> None:
    boundary = _box(179.0, -17.0, 2.0, 1.0)  # 179 E .. 181 E = 179 W, Fiji
    boundary["coordinates"][0] = [
        [lon - 360 * (lon > 180), lat] for lon, lat in boundary["coordinates"][0]
    ]
    doc = await _meshed(client, boundary=boundary, size=20_000.0, crs="OGC:CRS84")
    lon = np.asarray(doc["points"])[:, 0]
    assert lon.min() >= -180.0
    assert lon.max() <= 180.0
    assert (lon > 179.0).any()
    assert (lon < -179.0).any()
    area = np.ptp(np.asarray(doc["projected"]["points"]), axis=0)
    assert area[0] < 250_000  # about 213 km across, not 40,000
    geo = await _meshed(client, "geojson", boundary=boundary, size=20_000.0, crs="OGC:CRS84")
    kinds = set()
    for feature in geo["features"]:
        geom = feature["geometry"]
        if geom["type"] == "LineString":  # the tagged boundary lines follow the triangles
            continue
        kinds.add(geom["type"])
        polygons = [geom["coordinates"]] if geom["type"] == "Polygon" else geom["coordinates"]
        for polygon in polygons:
            for ring in polygon:
                assert ring[0] == ring[-1]  # closed
                assert all(-180.0 <= p[0] <= 180.0 for p in ring)
            assert _ring_area(polygon[0]) > 0  # counter-clockwise
    assert kinds == {"Polygon", "MultiPolygon"}  # the triangles over 180 degrees are cut


async def test_the_legacy_crs_member_is_read(client: httpx.AsyncClient) -> None:
    boundary = _box(500_000.0, 6_650_000.0, 2000.0, 2000.0)
    boundary["crs"] = {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}}
    doc = await _meshed(client, boundary=boundary, size=500.0)
    assert doc["crs"]["mesh"] == "EPSG:32633"


async def test_an_unknown_crs_is_422_at_inputs_crs(client: httpx.AsyncClient) -> None:
    r = await client.post(
        "/processes/mesh/execution",
        json={"inputs": {"boundary": _box(0, 0, 1, 1), "size": 0.1, "crs": "EPSG:0"}},
    )
    assert_problem(r, 422, pointer="/inputs/crs")


async def test_a_hemisphere_sized_region_is_422_at_the_boundary(client: httpx.AsyncClient) -> None:
    # Edges under 180 degrees of longitude (a longer one would cross the antimeridian).
    ring = [[-170, -60], [0, -60], [170, -60], [170, 60], [0, 60], [-170, 60], [-170, -60]]
    boundary = {"type": "Polygon", "coordinates": [ring]}
    inputs = {"boundary": boundary, "size": 1e6, "crs": "EPSG:4326"}
    r = await client.post("/processes/mesh/execution", json={"inputs": inputs})
    doc = assert_problem(r, 422, pointer="/inputs/boundary")
    assert "degrees of arc" in doc["detail"]


async def test_a_latitude_past_90_is_422_at_the_vertex(client: httpx.AsyncClient) -> None:
    boundary = {"type": "Polygon", "coordinates": [[[0, 80], [10, 80], [10, 95], [0, 80]]]}
    inputs = {"boundary": boundary, "size": 1e5, "crs": "EPSG:4326"}
    r = await client.post("/processes/mesh/execution", json={"inputs": inputs})
    assert_problem(r, 422, pointer="/inputs/boundary/coordinates/0/2")


def test_cli_crs_flag_writes_lonlat(tmp_path: Path) -> None:
    region = tmp_path / "box.geojson"
    region.write_text(json.dumps(_box(14.0, 60.0, 0.2, 0.1)))
    out = tmp_path / "box.json"
    args = ["mesh", str(region), "--crs", "EPSG:4326", "--size", "2000", "--smooth", "none"]
    assert main([*args, "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["crs"]["mesh"] == "EPSG:32633"
    pts = np.asarray(doc["points"])
    assert np.allclose(pts.min(axis=0), [14.0, 60.0])
    assert np.allclose(pts.max(axis=0), [14.2, 60.1])
    lengths, _ = geodesic_edge_lengths(doc)
    assert abs(np.median(lengths) / 2000.0 - 1.0) < 0.15


def test_cli_reads_a_geopackage_in_its_crs(tmp_path: Path) -> None:
    x0, y0 = 500_000.0, 6_650_000.0
    square = shapely.box(x0, y0, x0 + 3000.0, y0 + 2000.0)
    path = tmp_path / "region.gpkg"
    pyogrio.raw.write(
        str(path),
        geometry=np.array([shapely.to_wkb(square)], dtype=object),
        field_data=[np.array(["field"], dtype=object)],
        fields=["name"],
        geometry_type="Polygon",
        crs="EPSG:32633",
        driver="GPKG",
    )
    out = tmp_path / "region.geojson"
    assert main(["mesh", str(path), "--size", "500", "--smooth", "none", "-o", str(out)]) == 0
    geo = json.loads(out.read_text())
    triangles = [f for f in geo["features"] if f["geometry"]["type"] == "Polygon"]
    xy = np.asarray([p for f in triangles for p in f["geometry"]["coordinates"][0]])
    assert np.allclose(xy.min(axis=0), [x0, y0])
    assert np.allclose(xy.max(axis=0), [x0 + 3e3, y0 + 2e3])
