"""The mesh document as JSON (read and written) and as GeoJSON triangles (written).

>>> doc = {"points": [[0, 0], [1, 0], [0, 1]], "triangles": [[0, 1, 2]],
...        "cell_data": {"quality": [0.87]}}
>>> geo = orjson.loads(write_geojson(StoredResult(doc=doc), {}))
>>> geo["features"][0]["properties"]
{'triangle': 0, 'quality': 0.87}
>>> read_json(b'{"points": [], "triangles": []}')
{'points': [], 'triangles': []}
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import orjson

from ..geo.antimeridian import split_at_antimeridian
from .registry import ReadError, StoredResult

__all__ = ["read_json", "write_geojson", "write_json"]


def write_json(result: StoredResult, options: Mapping[str, str]) -> bytes:
    """The document as stored."""
    return result.raw


def read_json(data: bytes) -> dict[str, Any]:
    """A mesh document from JSON; :class:`ReadError` when it is not a JSON object."""
    try:  # the standard library's parser: it reads NaN, which validation then names
        doc = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ReadError(f"not JSON: {exc}") from None
    if not isinstance(doc, dict):
        raise ReadError(f"a mesh document is a JSON object, not {type(doc).__name__}")
    return doc


def _geographic(doc: Mapping[str, Any]) -> bool:
    crs = doc.get("crs")
    return crs == "wgs84" or (isinstance(crs, Mapping) and crs.get("geographic") is True)


def _geometry(ring: list[list[float]], geographic: bool) -> dict[str, Any]:
    """A triangle as a GeoJSON Polygon, or (lon/lat crossing 180 degrees) the MultiPolygon of
    its pieces east and west of the antimeridian, as RFC 7946 section 3.1.9 asks."""
    lons = [p[0] for p in ring]
    if not geographic or max(lons) - min(lons) <= 180.0:
        return {"type": "Polygon", "coordinates": [ring]}
    pieces = split_at_antimeridian(ring[:-1])
    return {
        "type": "MultiPolygon",
        "coordinates": [
            [[*o.tolist(), o[0].tolist()], *([*h.tolist(), h[0].tolist()] for h in hs)]
            for o, hs in pieces
        ],
    }


def write_geojson(result: StoredResult, options: Mapping[str, str]) -> bytes:
    """A FeatureCollection of the triangles, each carrying its ``cell_data`` figures (and its
    ``region_name``), then of the tagged lines, each carrying its ``tag`` and ``tag_name``;
    lon/lat results are RFC 7946 (counter-clockwise rings, triangles cut at the antimeridian)."""
    doc = result.doc
    pts = doc["points"]
    geographic = _geographic(doc)
    cells = doc.get("cell_data", {})
    names = list(cells)
    region_names = _region_names(doc)
    features = []
    for t, tri in enumerate(doc["triangles"]):
        ring = [pts[tri[0]], pts[tri[1]], pts[tri[2]], pts[tri[0]]]
        props: dict[str, Any] = {"triangle": t}
        props.update((name, cells[name][t]) for name in names)
        if region_names is not None:
            props["region_name"] = region_names[t]
        features.append(
            {"type": "Feature", "geometry": _geometry(ring, geographic), "properties": props}
        )
    features += _line_features(doc)
    return orjson.dumps({"type": "FeatureCollection", "features": features})


def _names(table: Mapping[str, int]) -> dict[int, str]:
    return {int(v): str(k) for k, v in table.items()}


def _region_names(doc: Mapping[str, Any]) -> list[str] | None:
    """The region name of each triangle, when the document names regions."""
    if "regions" not in doc or "region" not in doc.get("cell_data", {}):
        return None
    names = _names(doc["regions"])
    return [names.get(int(r), "") for r in doc["cell_data"]["region"]]


def _line_features(doc: Mapping[str, Any]) -> list[dict[str, Any]]:
    """A LineString per tagged line, with its tag id and name."""
    pts = doc["points"]
    tags = doc.get("line_data", {}).get("tag", [])
    names = _names(doc.get("tags", {}))
    return [
        {
            "type": "Feature",
            "geometry": {"type": "LineString", "coordinates": [pts[i], pts[j]]},
            "properties": {"line": n, "tag": int(t), "tag_name": names.get(int(t), "")},
        }
        for n, ((i, j), t) in enumerate(zip(doc.get("lines", []), tags, strict=True))
    ]
