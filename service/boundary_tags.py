"""Boundary tags as a GeoJSON Feature names them: ``properties.name`` names the region (and
prefixes its rings' default tags), ``properties.tags`` names runs of its rings.

A run is ``{"name": "inlet", "ring": 0, "from": 3, "to": 5}``: the edges from input vertex 3
to input vertex 5 of ring 0 (0 = outer ring, 1.. = holes, numbered as in the Feature's
``coordinates``), walking forward in input order and wrapping past the last vertex when ``to``
is not after ``from``; ``"polygon": k`` picks the k-th polygon of a MultiPolygon (default 0).

>>> square = [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]
>>> props = {"name": "duct", "tags": [{"name": "inlet", "from": 3, "to": 0}]}
>>> [(r.name, r.path.tolist()) for r in tag_runs(props, [square])]
[('inlet', [[0.0, 1.0], [0.0, 0.0]])]
>>> region_name(props)
'duct'
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from engine import TagRun

from .geojson import BoundaryInputError

__all__ = ["region_name", "tag_runs"]


def region_name(props: Mapping[str, Any]) -> str | None:
    """A Feature's ``properties.name`` when it is a non-empty string."""
    name = props.get("name")
    return name if isinstance(name, str) and name else None


def _open(ring: Any) -> np.ndarray:
    xy = np.asarray(ring, dtype=np.float64)[:, :2]
    return xy[:-1] if len(xy) > 1 and np.array_equal(xy[0], xy[-1]) else xy


def _index(run: Mapping[str, Any], key: str, upper: int, where: str, default: int = 0) -> int:
    v = run.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < upper:
        raise BoundaryInputError(
            f"{key} must be an integer from 0 to {upper - 1}, got {v!r}", f"{where}/{key}"
        )
    return v


def tag_runs(
    props: Mapping[str, Any], polygons: Sequence[Sequence[Any]], pointer: str = ""
) -> list[TagRun]:
    """The runs ``props["tags"]`` names on ``polygons`` (each a list of rings, outer first, as
    the Feature's coordinates); :class:`BoundaryInputError` pointing at the faulty entry."""
    runs = props.get("tags", [])
    where = f"{pointer}/properties/tags"
    if not isinstance(runs, list):
        raise BoundaryInputError("properties.tags must be a list of runs", where)
    out = []
    for i, run in enumerate(runs):
        at = f"{where}/{i}"
        if not isinstance(run, dict) or not isinstance(run.get("name"), str) or not run["name"]:
            raise BoundaryInputError(
                'a run is {"name": ..., "ring": r, "from": i, "to": j} with a non-empty name', at
            )
        rings = polygons[_index(run, "polygon", len(polygons), at)]
        ring = _open(rings[_index(run, "ring", len(rings), at)])
        start = _index(run, "from", len(ring), at)
        stop = _index(run, "to", len(ring), at)
        count = (stop - start) % len(ring) or len(ring)  # from == to: the whole ring
        out.append(TagRun(run["name"], ring[(start + np.arange(count + 1)) % len(ring)]))
    return out
