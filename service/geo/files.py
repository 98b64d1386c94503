"""Region files: GeoJSON directly; Shapefile, GeoPackage and KML through pyogrio (``geo`` extra).

:func:`read_region_file` returns the areas of a file as a GeoJSON FeatureCollection, with the CRS
its coordinates are in, ready for the boundary parser and :func:`~service.geo.crs.project_rings`.
Readers sit in a registry by file extension (:data:`READERS`); pyogrio is imported only by the
readers that need it.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .crs import legacy_crs
from .errors import GeoError, MissingDependency

__all__ = ["READERS", "RegionFile", "RegionFileError", "read_region_file"]


class RegionFileError(GeoError):
    """The file cannot be read as a region (unknown type, unreadable, or holding no area)."""


@dataclass(frozen=True)
class RegionFile:
    """What a region file holds."""

    #: the boundary input: a GeoJSON object (a FeatureCollection of the areas of a GIS file), or
    #: what a .json file holds (also ``{"outer", "holes"}`` or a bare list of rings)
    geojson: dict[str, Any] | list[Any]
    #: the CRS the coordinates are in (authority code or WKT); ``None`` when the file does not say:
    #: RFC 7946 GeoJSON is then lon/lat, while evomesh's own examples are planar, so callers decide.
    crs: str | None


Reader = Callable[[Path, str | int | None], RegionFile]


def _read_geojson(path: Path, layer: str | int | None) -> RegionFile:
    try:
        obj = json.loads(path.read_bytes())
    except (OSError, ValueError) as exc:
        raise RegionFileError(f"cannot read {path.name} as JSON: {exc}") from None
    if not isinstance(obj, dict | list):
        raise RegionFileError(f"{path.name} holds no GeoJSON object")
    crs = legacy_crs(obj) if isinstance(obj, dict) else None
    return RegionFile(obj, crs)


def _read_ogr(path: Path, layer: str | int | None) -> RegionFile:
    try:
        import pyogrio
        import pyogrio.errors
        import shapely
    except ImportError:
        raise MissingDependency(
            f"reading {path.suffix} files needs the optional 'geo' extra (pyogrio): "
            "pip install 'evomesh[geo]'"
        ) from None
    try:
        if layer is None:  # the first layer; naming it keeps GDAL quiet about the others
            layer = str(pyogrio.list_layers(path)[0][0])
        meta, _, wkb, columns = pyogrio.raw.read(path, layer=layer, force_2d=True)
    except (pyogrio.errors.DataSourceError, pyogrio.errors.DataLayerError, IndexError) as exc:
        raise RegionFileError(f"cannot read {path.name}: {exc}") from None
    geoms = shapely.from_wkb(wkb)
    areas = [shapely.GeometryType.POLYGON, shapely.GeometryType.MULTIPOLYGON]
    keep = np.flatnonzero(np.isin(shapely.get_type_id(geoms), areas)).tolist()
    if not keep:
        raise RegionFileError(f"{path.name} (layer {layer!r}) holds no Polygon or MultiPolygon")
    texts = shapely.to_geojson(geoms[keep])
    names = [str(n) for n in meta["fields"]]
    features = [
        {
            "type": "Feature",
            "geometry": json.loads(text),
            "properties": {n: _plain(col[i]) for n, col in zip(names, columns, strict=True)},
        }
        for i, text in zip(keep, texts, strict=True)
    ]
    return RegionFile({"type": "FeatureCollection", "features": features}, meta["crs"])


def _plain(value: Any) -> Any:
    """A JSON value for one attribute (numpy scalars to Python, dates to ISO text)."""
    if isinstance(value, np.datetime64):
        return str(value)
    if isinstance(value, np.generic):
        value = value.item()
    return None if isinstance(value, float) and not np.isfinite(value) else value


#: File extension (lower case) -> reader.
READERS: dict[str, Reader] = {
    ".geojson": _read_geojson,
    ".json": _read_geojson,
    ".shp": _read_ogr,
    ".gpkg": _read_ogr,
    ".kml": _read_ogr,
}


def read_region_file(path: str | Path, *, layer: str | int | None = None) -> RegionFile:
    """Read the areas of a region file, and the CRS they are in.

    ``layer`` picks a layer of a multi-layer file (GeoPackage, KML folders); the first by default.
    Raises :class:`RegionFileError` for an unknown type or unreadable file and
    :class:`~service.geo.errors.MissingDependency` when pyogrio is needed but not installed.

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = Path(d) / "r.geojson"
    ...     _ = p.write_text('{"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 1]]]}')
    ...     read_region_file(p).crs is None
    True
    """
    path = Path(path)
    reader = READERS.get(path.suffix.lower())
    if reader is None:
        known = ", ".join(sorted(READERS))
        raise RegionFileError(f"cannot read {path.name}: unknown file type (known: {known})")
    return reader(path, layer)
