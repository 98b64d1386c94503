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


def write_geojson(result: StoredResult, options: Mapping[str, str]) -> bytes:
    """A FeatureCollection of the triangles, each carrying its ``cell_data`` figures."""
    doc = result.doc
    pts = doc["points"]
    cells = doc.get("cell_data", {})
    names = list(cells)
    features = []
    for t, tri in enumerate(doc["triangles"]):
        ring = [pts[tri[0]], pts[tri[1]], pts[tri[2]], pts[tri[0]]]
        props: dict[str, Any] = {"triangle": t}
        props.update((name, cells[name][t]) for name in names)
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "Polygon", "coordinates": [ring]},
                "properties": props,
            }
        )
    return orjson.dumps({"type": "FeatureCollection", "features": features})
