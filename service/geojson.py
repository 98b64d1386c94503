"""Reading regions from GeoJSON (RFC 7946) or plain ``{"outer", "holes"}`` JSON.

:func:`parse_region` accepts a Polygon, MultiPolygon, Feature, FeatureCollection, a bare
coordinate list of rings, or ``{"outer": [[x, y], ...], "holes": [[[x, y], ...], ...]}``; it
returns the validated region with the JSON pointer of each ring, and raises the engine's refusal
of a region as a :class:`LocatedInvalidBoundary` pointing at the input's vertex, ring or polygon
at fault, so errors say exactly where the problem is. Given a ``crs``
the rings are projected to the meshing plane with :func:`service.geo.project_rings` (lon/lat
input is meshed in metres in a local projection).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from engine import InvalidBoundary, Region, make_region

from .geo import InvalidCoordinates, Projection, legacy_crs, project_rings

__all__ = [
    "BoundaryInputError",
    "LocatedInvalidBoundary",
    "ParsedRegion",
    "Parts",
    "build_region",
    "parse_region",
    "region_crs",
]


class BoundaryInputError(ValueError):
    """The boundary input is not a region; ``pointer`` is a JSON pointer into the input."""

    def __init__(self, message: str, pointer: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.pointer = pointer


class LocatedInvalidBoundary(BoundaryInputError):
    """The engine's :class:`engine.InvalidBoundary` (``cause``) located in the input: its
    message, and ``pointer`` to the input's vertex, ring or polygon at fault (in the input's
    numbering when the rings were densified). The engine's error is wrapped, not annotated, so
    that it keeps saying only what the engine knows."""

    def __init__(self, cause: InvalidBoundary, pointer: str) -> None:
        super().__init__(cause.message, pointer)
        self.cause = cause


@dataclass(frozen=True)
class ParsedRegion:
    """A validated region, with what is needed to point back into the input."""

    region: Region
    parts: Parts  #: the rings to mesh (in the meshing plane), for :func:`build_region`
    ring_pointers: tuple[tuple[str, ...], ...]  #: per part, per ring: JSON pointer of the ring
    properties: dict[str, Any]  #: the Feature's properties (first Feature's for collections)
    projection: Projection | None = None  #: the input CRS and the plane (``None``: planar)

    def crs(self) -> dict[str, Any] | None:
        """What a job stores and a result document carries about the CRS (``None``: planar):
        :meth:`service.geo.Projection.describe`, whose ``input`` and ``mesh`` names rebuild the
        way back (:func:`service.document.plane_to_input`)."""
        return None if self.projection is None else self.projection.describe()


def locate(
    ring_pointers: Sequence[Sequence[str]], part: int | None, ring: int | None, vertex: int | None
) -> str:
    """JSON pointer of a part/ring/vertex (``None``: not known) given the pointers of every
    ring; ``""`` when not even the part is known.

    >>> locate([("/coordinates/0", "/coordinates/1")], 0, 1, 4)
    '/coordinates/1/4'
    >>> locate([("/coordinates/0",)], 0, None, None)
    '/coordinates'
    """
    if part is None or part >= len(ring_pointers):
        return ""
    rings = ring_pointers[part]
    if ring is None or ring >= len(rings):
        return rings[0].rsplit("/", 1)[0] if rings else ""
    return rings[ring] if vertex is None else f"{rings[ring]}/{vertex}"


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


def region_crs(obj: Any, crs: str | None, coordinates: str = "planar") -> str | None:
    """The CRS of a boundary input: ``crs`` when given, else the GeoJSON's legacy ``crs``
    member, else lon/lat for ``coordinates="wgs84"`` (the older switch), else ``None`` (planar).

    >>> region_crs({"type": "Polygon", "coordinates": [], "crs": {"type": "name",
    ...     "properties": {"name": "EPSG:32633"}}}, None)
    'EPSG:32633'
    >>> region_crs({}, None, "wgs84")
    'OGC:CRS84'
    """
    if crs is not None:
        return crs
    legacy = legacy_crs(obj) if isinstance(obj, Mapping) else None
    if legacy is not None:
        return legacy
    return "OGC:CRS84" if coordinates == "wgs84" else None


def parse_region(
    obj: Any, *, pointer: str = "", crs: str | None = None, densify: float | None = None
) -> ParsedRegion:
    """Parse and validate a region, projected to its meshing plane when it has a ``crs``.

    Raises :class:`BoundaryInputError` for malformed input (a position outside the CRS's range
    included), :class:`LocatedInvalidBoundary` (a subclass) for a region the engine cannot
    mesh and :class:`service.geo.GeoError` for an unknown CRS or a region too large
    for one projection. ``densify`` (mesh-plane units) splits lon/lat edges to follow them.

    >>> p = parse_region({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 0]]]})
    >>> p.region.area
    0.5
    >>> p.ring_pointers
    (('/coordinates/0',),)
    >>> parse_region([[[14, 60], [15, 60], [15, 61]]], crs="EPSG:4326").crs()["mesh"]
    'EPSG:32633'
    """
    found, props = _parts(obj, pointer)
    ring_pointers = tuple(ptrs for _, ptrs in found)
    parts: Parts = [(_floats(outer), [_floats(h) for h in holes]) for (outer, holes), _ in found]
    projection = None
    if crs is not None:
        try:
            projection = project_rings(parts, crs, densify=densify)
        except InvalidCoordinates as exc:
            at = ring_pointers[exc.part][exc.ring]
            raise BoundaryInputError(exc.message, f"{at}/{exc.vertex}") from None
        parts = [(o.tolist(), [h.tolist() for h in hs]) for o, hs in projection.parts]
    try:
        region = build_region(parts)
    except InvalidBoundary as exc:
        part, ring, vertex = exc.part, exc.ring, exc.vertex
        if projection is not None and part is not None and ring is not None and vertex is not None:
            vertex = projection.input_vertex(part, ring, vertex)  # densified: input numbering
        at = locate(ring_pointers, part, ring, vertex) or pointer
        raise LocatedInvalidBoundary(exc, at) from exc
    return ParsedRegion(region, parts, ring_pointers, props, projection)


def build_region(parts: Parts) -> Region:
    """The region of ``parts`` (rings in the meshing plane, as a job stores them).

    >>> build_region([([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]], [])]).area
    2.0
    """
    return make_region(list(parts))
