"""Region files: GeoJSON read directly; GeoPackage, Shapefile and KML via pyogrio."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pyogrio.raw
import pytest
import shapely

from service.geo import project_rings, resolve_crs
from service.geo.errors import MissingDependency
from service.geo.files import READERS, RegionFileError, read_region_file

SQUARE = shapely.Polygon(
    [(500_000, 6_650_000), (501_000, 6_650_000), (501_000, 6_651_000), (500_000, 6_651_000)],
    [[(500_400, 6_650_400), (500_400, 6_650_600), (500_600, 6_650_600), (500_600, 6_650_400)]],
)


def _write(path: Path, geoms: list[shapely.Geometry], crs: str, driver: str) -> None:
    names = np.array([f"area {i}" for i in range(len(geoms))], dtype=object)
    pyogrio.raw.write(
        path,
        shapely.to_wkb(np.array(geoms, dtype=object)),
        [names],
        ["name"],
        driver=driver,
        geometry_type="Unknown" if driver != "ESRI Shapefile" else "Polygon",
        crs=crs,
    )


@pytest.mark.parametrize(("suffix", "driver"), [(".gpkg", "GPKG"), (".shp", "ESRI Shapefile")])
def test_projected_areas_from_a_gis_file(tmp_path: Path, suffix: str, driver: str) -> None:
    path = tmp_path / f"region{suffix}"
    _write(path, [SQUARE], "EPSG:32633", driver)
    got = read_region_file(path)
    assert got.crs is not None
    assert resolve_crs(got.crs).to_epsg() == 32633
    assert isinstance(got.geojson, dict)
    (feature,) = got.geojson["features"]
    assert feature["properties"] == {"name": "area 0"}
    assert shapely.geometry.shape(feature["geometry"]).equals(SQUARE)


def test_only_areas_are_kept(tmp_path: Path) -> None:
    path = tmp_path / "mixed.gpkg"
    _write(
        path,
        [shapely.Point(0, 0), SQUARE, shapely.LineString([(0, 0), (1, 1)])],
        "EPSG:32633",
        "GPKG",
    )
    got = read_region_file(path)
    assert isinstance(got.geojson, dict)
    assert [f["properties"]["name"] for f in got.geojson["features"]] == ["area 1"]


def test_lon_lat_kml(tmp_path: Path) -> None:
    path = tmp_path / "area.kml"
    box = shapely.box(14.0, 60.0, 14.1, 60.05)
    _write(path, [box], "EPSG:4326", "KML")
    got = read_region_file(path)
    assert got.crs is not None
    assert isinstance(got.geojson, dict)
    ring = got.geojson["features"][0]["geometry"]["coordinates"][0]
    assert np.array(ring)[:, 0].max() == pytest.approx(14.1)  # x is longitude
    proj = project_rings([(ring, [])], got.crs)
    assert proj.mesh_crs is not None
    assert proj.mesh_crs.to_epsg() == 32633


def test_geojson_with_a_legacy_crs_member(tmp_path: Path) -> None:
    doc = {
        "type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
        "features": [
            {"type": "Feature", "properties": {}, "geometry": shapely.geometry.mapping(SQUARE)}
        ],
    }
    path = tmp_path / "r.geojson"
    path.write_text(json.dumps(doc))
    got = read_region_file(path)
    assert got.crs == "urn:ogc:def:crs:EPSG::32633"
    assert got.geojson == json.loads(json.dumps(doc))


def test_unknown_type_and_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(RegionFileError, match="unknown file type"):
        read_region_file(tmp_path / "r.dxf")
    bad = tmp_path / "bad.gpkg"
    bad.write_bytes(b"not a geopackage")
    with pytest.raises(RegionFileError, match=r"cannot read bad\.gpkg"):
        read_region_file(bad)
    broken = tmp_path / "broken.json"
    broken.write_text("{")
    with pytest.raises(RegionFileError, match="as JSON"):
        read_region_file(broken)


def test_missing_pyogrio_is_a_clear_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "pyogrio", None)
    with pytest.raises(MissingDependency, match=r"evomesh\[geo\]"):
        read_region_file(tmp_path / "region.shp")


def test_every_gis_format_is_registered() -> None:
    assert {".geojson", ".json", ".shp", ".gpkg", ".kml"} <= set(READERS)
