"""Reading regions from GeoJSON (RFC 7946) or plain ``{"outer", "holes"}`` JSON.

:func:`parse_region` accepts a Polygon, MultiPolygon, Feature, FeatureCollection, a bare
coordinate list of rings, or ``{"outer": [[x, y], ...], "holes": [[[x, y], ...], ...]}``; it
returns the validated region and a function that turns an engine error's (part, ring, vertex)
into a JSON pointer into the input, so errors say exactly where the problem is.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from engine import InvalidBoundary, Region, make_region

__all__ = [
    "BoundaryInputError",
    "ParsedRegion",
    "Parts",
    "build_region",
    "parse_region",
    "project_wgs84",
]

_EARTH_RADIUS_M = 6_371_008.8


class BoundaryInputError(ValueError):
    """The boundary input is not a region; ``pointer`` is a JSON pointer into the input."""

    def __init__(self, message: str, pointer: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.pointer = pointer


@dataclass(frozen=True)
class ParsedRegion:
    """A validated region, with what is needed to point back into the input."""

    region: Region
    parts: Parts  #: the rings as read (lon/lat for wgs84), for :func:`build_region`
    ring_pointers: tuple[tuple[str, ...], ...]  #: per part, per ring: JSON pointer of the ring
    properties: dict[str, Any]  #: the Feature's properties (first Feature's for collections)
    to_lonlat: Callable[[np.ndarray], np.ndarray] | None = None  #: inverse of the wgs84 projection

    def pointer(self, exc: InvalidBoundary) -> str:
        """JSON pointer (relative to the boundary input) of an engine error's location."""
        return locate(self.ring_pointers, exc)


def locate(ring_pointers: Sequence[Sequence[str]], exc: InvalidBoundary) -> str:
    """JSON pointer of ``exc``'s part/ring/vertex given the pointers of every ring."""
    if exc.part is None or exc.part >= len(ring_pointers):
        return ""
    rings = ring_pointers[exc.part]
    if exc.ring is None or exc.ring >= len(rings):
        ptr = rings[0].rsplit("/", 1)[0] if rings else ""
        return ptr
    ptr = rings[exc.ring]
    return ptr if exc.vertex is None else f"{ptr}/{exc.vertex}"


_Part = tuple[Any, list[Any]]
#: A region as plain data: per part, its outer ring and its holes, each a list of [x, y] floats.
#: This, not the client's JSON, is what a job stores and a worker receives.
Parts = list[tuple[list[list[float]], list[list[list[float]]]]]


def _floats(ring: Any) -> list[list[float]]:
    # Positions were checked to start with two numbers; a third (altitude) is dropped.
    return [[float(p[0]), float(p[1])] for p in ring]


def _polygon_rings(coords: Any, ptr: str) -> tuple[_Part, tuple[str, ...]]:
    if not isinstance(coords, list) or not coords:
        raise BoundaryInputError("a Polygon needs a non-empty list of rings", ptr)
    for i, ring in enumerate(coords):
        _check_ring(ring, f"{ptr}/{i}")
    return (coords[0], list(coords[1:])), tuple(f"{ptr}/{i}" for i in range(len(coords)))


def _check_ring(ring: Any, ptr: str) -> None:
    if not isinstance(ring, list):
        raise BoundaryInputError("a ring must be a list of [x, y] positions", ptr)
    for j, pos in enumerate(ring):
        if (
            not isinstance(pos, list | tuple)
            or len(pos) < 2
            or not all(isinstance(c, int | float) and not isinstance(c, bool) for c in pos)
        ):
            raise BoundaryInputError("a position must be [x, y] numbers", f"{ptr}/{j}")


def _geometry(geom: Any, ptr: str) -> list[tuple[_Part, tuple[str, ...]]]:
    if not isinstance(geom, dict):
        raise BoundaryInputError("a geometry must be a JSON object", ptr)
    kind = geom.get("type")
    coords = geom.get("coordinates")
    if kind == "Polygon":
        return [_polygon_rings(coords, f"{ptr}/coordinates")]
    if kind == "MultiPolygon":
        if not isinstance(coords, list) or not coords:
            raise BoundaryInputError(
                "a MultiPolygon needs a non-empty list of polygons", f"{ptr}/coordinates"
            )
        return [_polygon_rings(p, f"{ptr}/coordinates/{i}") for i, p in enumerate(coords)]
    if kind == "GeometryCollection":
        out = []
        for i, g in enumerate(geom.get("geometries") or []):
            out += _geometry(g, f"{ptr}/geometries/{i}")
        if not out:
            raise BoundaryInputError("the GeometryCollection holds no polygon", ptr)
        return out
    raise BoundaryInputError(
        f"geometry type {kind!r} is not an area; use Polygon or MultiPolygon", f"{ptr}/type"
    )


def _parts(obj: Any, ptr: str) -> tuple[list[tuple[_Part, tuple[str, ...]]], dict[str, Any]]:
    if isinstance(obj, list):  # bare list of rings
        return [_polygon_rings(obj, ptr)], {}
    if not isinstance(obj, dict):
        raise BoundaryInputError("the boundary must be a GeoJSON object or a list of rings", ptr)
    if "outer" in obj:
        _check_ring(obj["outer"], f"{ptr}/outer")
        holes = obj.get("holes") or []
        if not isinstance(holes, list):
            raise BoundaryInputError("holes must be a list of rings", f"{ptr}/holes")
        for i, h in enumerate(holes):
            _check_ring(h, f"{ptr}/holes/{i}")
        ptrs = (f"{ptr}/outer", *(f"{ptr}/holes/{i}" for i in range(len(holes))))
        return [((obj["outer"], list(holes)), ptrs)], {}
    kind = obj.get("type")
    if kind == "Feature":
        props = obj.get("properties") or {}
        if not isinstance(props, dict):
            raise BoundaryInputError(
                "a Feature's properties must be an object or null", f"{ptr}/properties"
            )
        if obj.get("geometry") is None:
            raise BoundaryInputError("the Feature has no geometry", f"{ptr}/geometry")
        return _geometry(obj["geometry"], f"{ptr}/geometry"), dict(props)
    if kind == "FeatureCollection":
        feats = obj.get("features")
        if not isinstance(feats, list) or not feats:
            raise BoundaryInputError("the FeatureCollection has no features", f"{ptr}/features")
        out: list[tuple[_Part, tuple[str, ...]]] = []
        first_props: dict[str, Any] = {}
        for i, f in enumerate(feats):
            parts, props = _parts(f, f"{ptr}/features/{i}")
            out += parts
            if i == 0:
                first_props = props
        return out, first_props
    if kind in {"Polygon", "MultiPolygon", "GeometryCollection"}:
        return _geometry(obj, ptr), {}
    raise BoundaryInputError(
        f"unsupported boundary type {kind!r}; use a GeoJSON Polygon, MultiPolygon, Feature, "
        'FeatureCollection or {"outer": [...], "holes": [...]}',
        f"{ptr}/type" if "type" in obj else ptr,
    )


def project_wgs84(
    parts: list[_Part],
) -> tuple[list[_Part], Callable[[np.ndarray], np.ndarray]]:
    """Project lon/lat rings to a local metric frame (metres) centred on the region.

    Uses the equirectangular tangent plane at the region's centre, good to well under 0.1% for
    regions a few tens of kilometres across. Returns the projected parts and the inverse map.
    """
    pts = np.concatenate(
        [np.asarray(r, dtype=np.float64)[:, :2] for o, hs in parts for r in [o, *hs]]
    )
    lon0, lat0 = float(pts[:, 0].mean()), float(pts[:, 1].mean())
    k = np.cos(np.radians(lat0))

    def fwd(a: Any) -> np.ndarray:
        xy = np.asarray(a, dtype=np.float64)[:, :2]
        return np.stack(
            [
                np.radians(xy[:, 0] - lon0) * _EARTH_RADIUS_M * k,
                np.radians(xy[:, 1] - lat0) * _EARTH_RADIUS_M,
            ],
            axis=1,
        )

    def inverse(xy: np.ndarray) -> np.ndarray:
        return np.stack(
            [
                lon0 + np.degrees(xy[:, 0] / (_EARTH_RADIUS_M * k)),
                lat0 + np.degrees(xy[:, 1] / _EARTH_RADIUS_M),
            ],
            axis=1,
        )

    return [(fwd(o), [fwd(h) for h in hs]) for o, hs in parts], inverse


def parse_region(obj: Any, *, pointer: str = "", wgs84: bool = False) -> ParsedRegion:
    """Parse and validate a region.

    Raises :class:`BoundaryInputError` for malformed input and :class:`engine.InvalidBoundary`
    (with ``exc.pointer`` set) for a region that cannot be meshed. With ``wgs84`` the input is
    lon/lat and is projected to a local metric frame; ``to_lonlat`` maps mesh points back.

    >>> p = parse_region({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 0]]]})
    >>> p.region.area
    0.5
    >>> p.ring_pointers
    (('/coordinates/0',),)
    """
    found, props = _parts(obj, pointer)
    ring_pointers = tuple(ptrs for _, ptrs in found)
    parts: Parts = [(_floats(outer), [_floats(h) for h in holes]) for (outer, holes), _ in found]
    if wgs84:
        for ptrs, (outer, holes) in zip(ring_pointers, parts, strict=True):
            for ptr, ring in zip(ptrs, [outer, *holes], strict=True):
                xy = np.asarray(ring, dtype=np.float64).reshape(-1, 2)
                bad = np.flatnonzero((np.abs(xy[:, 0]) > 180) | (np.abs(xy[:, 1]) > 90))
                if bad.size:
                    raise BoundaryInputError(
                        "longitude must be within [-180, 180] and latitude within [-90, 90]",
                        f"{ptr}/{bad[0]}",
                    )
    try:
        region, to_lonlat = build_region(parts, wgs84=wgs84)
    except InvalidBoundary as exc:
        exc.pointer = locate(ring_pointers, exc) or pointer  # type: ignore[attr-defined]
        raise
    return ParsedRegion(region, parts, ring_pointers, props, to_lonlat)


def build_region(
    parts: Parts, *, wgs84: bool = False
) -> tuple[Region, Callable[[np.ndarray], np.ndarray] | None]:
    """The region of ``parts`` (projected first with ``wgs84``) and the inverse projection.

    >>> region, _ = build_region([([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]], [])])
    >>> region.area
    2.0
    """
    rings: list[_Part] = list(parts)
    to_lonlat = None
    if wgs84:
        rings, to_lonlat = project_wgs84(rings)
    return make_region(rings), to_lonlat
