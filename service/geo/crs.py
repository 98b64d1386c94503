"""Coordinate reference systems: which plane a region is meshed in, and the way back.

:func:`project_rings` takes rings in any CRS pyproj understands and returns a
:class:`Projection`: planar rings to mesh, vectorised ``forward``/``inverse`` transforms and the
largest length error the plane makes over the region. Projected input is meshed in its own
coordinates; lon/lat input is meshed in metres in a projection chosen for the region
(:func:`local_crs`): its UTM zone when it fits in one, else an azimuthal equidistant projection
centred on it. Regions more than a hemisphere across are refused (:class:`RegionTooLarge`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS, Proj, Transformer
from pyproj.crs import ProjectedCRS
from pyproj.crs.coordinate_operation import AzimuthalEquidistantConversion, UTMConversion
from pyproj.exceptions import CRSError, ProjError

from .antimeridian import FloatArray, Part, normalize_longitudes, unwrap_parts
from .errors import GeoError, InvalidCoordinates, RegionTooLarge, UnknownCRS

__all__ = [
    "ALIASES",
    "Projection",
    "crs_name",
    "legacy_crs",
    "local_crs",
    "project_rings",
    "resolve_crs",
    "scale_error",
]

#: Names accepted besides what pyproj reads; "wgs84" is the service's older lon/lat switch.
ALIASES = {"wgs84": "OGC:CRS84"}
#: Largest angular distance (degrees of arc) from the centre one local projection may cover.
MAX_ARC_DEG = 90.0
#: UTM is used up to these latitudes (beyond them UTM gives way to the polar grids).
_UTM_LATITUDES = (-80.0, 84.0)
_WGS84 = CRS.from_epsg(4326)


def resolve_crs(crs: str | Mapping[str, Any] | CRS) -> CRS:
    """The pyproj CRS for ``crs`` (an authority code, URN, WKT, PROJ string or PROJJSON dict).

    Raises :class:`UnknownCRS` naming the input when pyproj cannot read it.

    >>> resolve_crs("wgs84").to_string()
    'OGC:CRS84'
    >>> resolve_crs("urn:ogc:def:crs:EPSG::32633").to_epsg()
    32633
    >>> resolve_crs("EPSG:0")
    Traceback (most recent call last):
    ...
    service.geo.errors.UnknownCRS: unknown coordinate reference system 'EPSG:0': ...
    """
    if isinstance(crs, CRS):
        return crs
    if isinstance(crs, str):
        crs = ALIASES.get(crs.strip().lower(), crs)
    try:
        out = CRS.from_user_input(dict(crs) if isinstance(crs, Mapping) else crs)
    except CRSError as exc:
        raise UnknownCRS(crs, str(exc).split(": (")[0]) from None
    if not (out.is_geographic or out.is_projected):
        raise UnknownCRS(crs, f"{out.name} is not a geographic or projected 2-D system")
    return out


def crs_name(crs: CRS) -> str:
    """``crs`` as short text: its authority code when it has one, else WKT.

    >>> crs_name(resolve_crs("EPSG:32633"))
    'EPSG:32633'
    """
    auth = crs.to_authority()
    return f"{auth[0]}:{auth[1]}" if auth else crs.to_wkt()


def legacy_crs(obj: Mapping[str, Any]) -> str | None:
    """The CRS named by a GeoJSON object's pre-RFC 7946 ``crs`` member, or ``None`` if absent.

    >>> legacy_crs({"type": "FeatureCollection", "features": [],
    ...             "crs": {"type": "name", "properties": {"name": "EPSG:32633"}}})
    'EPSG:32633'
    """
    member = obj.get("crs")
    if member is None:
        return None
    props = member.get("properties") if isinstance(member, Mapping) else None
    name = props.get("name") if isinstance(props, Mapping) else None
    if not (isinstance(member, Mapping) and member.get("type") == "name" and isinstance(name, str)):
        raise UnknownCRS(
            member,
            'a legacy "crs" member must be {"type": "name", "properties": '
            '{"name": "<CRS>"}} (linked CRSs are not supported)',
        )
    return name


def local_crs(lonlat: FloatArray, geodetic: CRS = _WGS84) -> CRS:
    """A projected CRS that keeps lengths true over the lon/lat positions ``lonlat``.

    The region's UTM zone when every position lies in it, else an azimuthal equidistant
    projection centred on the region's longitude/latitude box; both on ``geodetic``'s datum.
    ``lonlat`` is continuous in longitude (see :func:`~service.geo.antimeridian.unwrap_parts`).

    >>> local_crs(np.array([[14.0, 60.0], [16.0, 61.0]])).to_epsg()
    32633
    >>> local_crs(np.array([[5.0, 55.0], [15.0, 65.0]])).name
    'Azimuthal equidistant centred on 60.000000 10.000000'
    """
    lon0, lat0 = _centre(lonlat)
    zone = math.floor((lon0 + 180.0) / 6.0) % 60 + 1
    meridian = zone * 6.0 - 183.0
    dlon = (lonlat[:, 0] - meridian + 180.0) % 360.0 - 180.0
    lat_lo, lat_hi = float(lonlat[:, 1].min()), float(lonlat[:, 1].max())
    if (
        np.abs(dlon).max() <= 3.0 + 1e-9
        and _UTM_LATITUDES[0] <= lat_lo <= lat_hi <= _UTM_LATITUDES[1]
    ):
        south = lat0 < 0.0
        if geodetic.datum == _WGS84.datum:
            return CRS.from_epsg((32700 if south else 32600) + zone)
        hemisphere = "S" if south else "N"
        return ProjectedCRS(
            UTMConversion(str(zone), hemisphere),
            name=f"UTM zone {zone}{hemisphere}",
            geodetic_crs=geodetic,
        )
    lon_c = lon0 - 360.0 * round(lon0 / 360.0)
    return ProjectedCRS(
        AzimuthalEquidistantConversion(lat0, lon_c),
        name=f"Azimuthal equidistant centred on {lat0:.6f} {lon_c:.6f}",
        geodetic_crs=geodetic,
    )


def _centre(lonlat: FloatArray) -> tuple[float, float]:
    lo, hi = lonlat.min(axis=0), lonlat.max(axis=0)
    return 0.5 * float(lo[0] + hi[0]), 0.5 * float(lo[1] + hi[1])


def _check_extent(lonlat: FloatArray) -> None:
    lon0, lat0 = np.radians(_centre(lonlat))
    lon, lat = np.radians(lonlat[:, 0]), np.radians(lonlat[:, 1])
    cos_arc = np.sin(lat0) * np.sin(lat) + np.cos(lat0) * np.cos(lat) * np.cos(lon - lon0)
    arc = float(np.degrees(np.arccos(np.clip(cos_arc, -1.0, 1.0))).max())
    if arc > MAX_ARC_DEG:
        raise RegionTooLarge(
            f"the region reaches {arc:.1f} degrees of arc from its centre, more than the "
            f"{MAX_ARC_DEG:g} one projection can keep; split it, or send it in a projected CRS"
        )


def scale_error(crs: CRS, lonlat: FloatArray) -> float:
    """Largest relative length error of ``crs``'s plane at the lon/lat positions ``lonlat``.

    From the axes of PROJ's Tissot indicatrix, the largest and smallest scale in any direction at
    a point (the scales along meridians and parallels miss the extremes of non-conformal maps):
    0.001 means a length measured in the plane is within 0.1% of the same length on the
    ellipsoid. ``nan`` when PROJ cannot tell.

    >>> round(scale_error(resolve_crs("EPSG:32633"), np.array([[15.0, 0.0], [18.0, 0.0]])), 5)
    0.00098
    """
    try:
        f = Proj(crs).get_factors(lonlat[:, 0], lonlat[:, 1])
    except (CRSError, ProjError):
        return math.nan
    scales = np.concatenate([f.tissot_semimajor, f.tissot_semiminor])
    return float(np.abs(scales - 1.0).max()) if np.isfinite(scales).all() else math.nan


@dataclass(frozen=True)
class Projection:
    """Rings ready to mesh, and the transforms between the input CRS and the meshing plane.

    Made by :func:`project_rings`. For planar input (no CRS) both transforms are the identity.
    """

    parts: tuple[Part, ...]  #: the rings to mesh, in the meshing plane (metres for lon/lat input)
    source_crs: CRS | None  #: the input's CRS (``None``: planar, no CRS)
    mesh_crs: CRS | None  #: the CRS of the meshing plane
    tolerance: (
        float  #: largest relative length error of the plane over the region's box (nan: unknown)
    )
    to_mesh: Transformer | None  #: source -> plane (``None``: the identity)
    to_source: Transformer | None  #: plane -> source
    #: per part, per ring: the input vertex each vertex of ``parts`` starts from (it lies on the
    #: input edge from there); ``None`` when the rings were not densified (the same numbering)
    origins: tuple[tuple[NDArray[np.int64], ...], ...] | None = None

    @property
    def geographic(self) -> bool:
        """Whether the input is lon/lat (then sizes are metres and results go back to lon/lat)."""
        return self.source_crs is not None and self.source_crs.is_geographic

    def forward(self, xy: ArrayLike) -> FloatArray:
        """(n, 2) positions in the input CRS -> the meshing plane."""
        pts = np.array(xy, dtype=np.float64, ndmin=2)[:, :2]
        if self.to_mesh is None:
            return pts
        x, y = self.to_mesh.transform(pts[:, 0], pts[:, 1], errcheck=True)
        return np.column_stack([x, y])

    def inverse(self, xy: ArrayLike) -> FloatArray:
        """(n, 2) positions in the meshing plane -> the input CRS (longitudes in [-180, 180])."""
        pts = np.array(xy, dtype=np.float64, ndmin=2)[:, :2]
        if self.to_source is None:
            return pts
        x, y = self.to_source.transform(pts[:, 0], pts[:, 1], errcheck=True)
        out = np.column_stack([x, y])
        return normalize_longitudes(out) if self.geographic else out

    def input_vertex(self, part: int, ring: int, vertex: int) -> int:
        """The input vertex number of ``parts[part]``'s ring ``ring`` vertex ``vertex``.

        For pointing an :class:`engine.InvalidBoundary` back into the input after densifying.
        """
        if self.origins is None:
            return vertex
        return int(self.origins[part][ring][vertex])

    def forward_path(
        self, xy: ArrayLike, *, closed: bool = False, densify: float | None = None
    ) -> FloatArray:
        """A line (or, ``closed``, a ring) in the input CRS -> the meshing plane.

        For lon/lat input the path is taken continuous across the antimeridian and, with
        ``densify``, split evenly so its pieces (straight in lon/lat) are about that long in the
        plane, as :func:`project_rings` does for rings. Use it for constraint lines and
        refinement areas; :meth:`forward` maps loose points.

        >>> p = project_rings([([[179, 0], [-179, 0], [-179, 1]], [])], "EPSG:4326")
        >>> line = p.forward_path([[179.5, 0.5], [-179.5, 0.5]], densify=50_000.0)
        >>> len(line), bool(np.ptp(line[:, 0]) < 120_000)
        (4, True)
        """
        pts = np.array(xy, dtype=np.float64, ndmin=2)[:, :2]
        if not self.geographic:
            return self.forward(pts)
        pts[:, 0] = np.unwrap(pts[:, 0], period=360.0)
        if densify is not None:
            pts = _densify(pts, self.forward, densify, closed=closed)[0]
        return self.forward(pts)

    def describe(self) -> dict[str, Any]:
        """The CRS facts a result document carries (JSON-ready).

        >>> project_rings([([[14, 60], [16, 60], [16, 61]], [])], "wgs84").describe()["mesh"]
        'EPSG:32633'
        """
        return {
            "input": crs_name(self.source_crs) if self.source_crs else None,
            "mesh": crs_name(self.mesh_crs) if self.mesh_crs else None,
            "mesh_name": self.mesh_crs.name if self.mesh_crs else None,
            "geographic": self.geographic,
            "length_tolerance": None if math.isnan(self.tolerance) else self.tolerance,
        }


def project_rings(
    parts: Sequence[tuple[ArrayLike, Sequence[ArrayLike]]],
    crs: str | Mapping[str, Any] | CRS | None,
    *,
    densify: float | None = None,
    max_scale_error: float | None = None,
) -> Projection:
    """Project a region's rings ``[(outer, holes), ...]`` given in ``crs`` to a meshing plane.

    Parameters
    ----------
    parts:
        Per polygon, its outer ring and holes, each a sequence of ``[x, y]`` (lon/lat for
        geographic CRSs, in that order whatever the CRS's axis order).
    crs:
        Anything :func:`resolve_crs` takes; ``None`` means planar coordinates with no CRS.
    densify:
        For lon/lat input: split edges (straight in lon/lat, as RFC 7946 has them) so that no
        piece is longer than about this in the plane; pass the mesh size so the boundary
        follows the edges.
    max_scale_error:
        Raise :class:`RegionTooLarge` when the plane's length error exceeds this.

    >>> p = project_rings([([[14, 60], [16, 60], [16, 61], [14, 61]], [])], "EPSG:4326")
    >>> p.mesh_crs.to_epsg(), round(p.tolerance, 4)
    (32633, 0.0004)
    >>> np.round(p.inverse(p.parts[0][0])[0], 9).tolist()
    [14.0, 60.0]
    """
    if crs is None:
        planar = [(_as_xy(o), [_as_xy(h) for h in hs]) for o, hs in parts]
        return Projection(tuple(planar), None, None, 0.0, None, None)
    source = resolve_crs(crs)
    if source.is_geographic:
        return _project_geographic(parts, source, densify, max_scale_error)
    rings = [(_as_xy(o), [_as_xy(h) for h in hs]) for o, hs in parts]
    tolerance = math.nan
    geodetic = source.geodetic_crs
    if geodetic is not None:
        xy = _sample(rings)
        lon, lat = Transformer.from_crs(source, geodetic, always_xy=True).transform(
            xy[:, 0], xy[:, 1]
        )
        tolerance = scale_error(source, np.column_stack([lon, lat]))
    _check_tolerance(tolerance, max_scale_error)
    return Projection(tuple(rings), source, source, tolerance, None, None)


def _as_xy(ring: ArrayLike) -> FloatArray:
    return np.array(ring, dtype=np.float64, ndmin=2)[:, :2]


def _project_geographic(
    parts: Sequence[tuple[ArrayLike, Sequence[ArrayLike]]],
    source: CRS,
    densify: float | None,
    max_scale_error: float | None,
) -> Projection:
    unit = source.axis_info[0].unit_name if source.axis_info else "degree"
    if unit != "degree":
        raise GeoError(f"geographic CRS {source.name!r} is in {unit}s; use one in degrees")
    _check_latitudes(parts)
    rings = unwrap_parts(parts)
    pts = np.concatenate([r for o, hs in rings for r in (o, *hs)])
    _check_extent(pts)
    geodetic = source.geodetic_crs or source
    target = local_crs(pts, geodetic)
    to_mesh = Transformer.from_crs(source, target, always_xy=True)
    to_source = Transformer.from_crs(target, source, always_xy=True)

    def fwd(r: FloatArray) -> FloatArray:
        x, y = to_mesh.transform(r[:, 0], r[:, 1], errcheck=True)
        return np.column_stack([x, y])

    origins = None
    if densify is not None:
        split = [[_densify(r, fwd, densify) for r in (o, *hs)] for o, hs in rings]
        rings = [(d[0][0], [r for r, _ in d[1:]]) for d in split]
        origins = tuple(tuple(start for _, start in d) for d in split)
    tolerance = scale_error(target, _sample(rings))
    _check_tolerance(tolerance, max_scale_error)
    planar = tuple((fwd(o), [fwd(h) for h in hs]) for o, hs in rings)
    return Projection(planar, source, target, tolerance, to_mesh, to_source, origins)


def _check_latitudes(parts: Sequence[tuple[ArrayLike, Sequence[ArrayLike]]]) -> None:
    for ip, (outer, holes) in enumerate(parts):
        for ir, ring in enumerate([outer, *holes]):
            xy = _as_xy(ring)
            bad = np.flatnonzero(~np.isfinite(xy).all(axis=1) | (np.abs(xy[:, 1]) > 90.0))
            if bad.size:
                raise InvalidCoordinates(
                    f"part {ip} ring {ir} vertex {bad[0]}: a position must be finite, its latitude "
                    "within [-90, 90] "
                    "(positions are [longitude, latitude])",
                    part=ip,
                    ring=ir,
                    vertex=int(bad[0]),
                )


def _check_tolerance(tolerance: float, limit: float | None) -> None:
    if limit is not None and tolerance > limit:
        raise RegionTooLarge(
            f"lengths in one projection are off by up to {100 * tolerance:.2g}% over this region, "
            f"more than the {100 * limit:.2g}% allowed; split the region"
        )


def _densify(
    path: FloatArray, fwd: Callable[[FloatArray], FloatArray], max_len: float, closed: bool = True
) -> tuple[FloatArray, NDArray[np.int64]]:
    """Split each segment of ``path`` evenly (in its own coordinates) into pieces of about
    ``max_len`` in the plane ``fwd`` maps to; a ring stays open, a line keeps its last vertex.
    Also returns, for each new vertex, the index of the input vertex its segment starts at."""
    if not (math.isfinite(max_len) and max_len > 0):
        raise ValueError(f"densify must be a positive length, got {max_len}")
    pts = np.vstack([path, path[:1]]) if closed else path
    seg = np.hypot(*np.diff(fwd(pts), axis=0).T)
    n = np.maximum(1, np.ceil(seg / max_len)).astype(np.int64)
    start = np.repeat(np.arange(n.size), n)
    t = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n)
    out = pts[start] + t[:, None] * (pts[start + 1] - pts[start])
    if closed:
        return out, start
    return np.vstack([out, pts[-1:]]), np.append(start, len(pts) - 1)


def _sample(parts: Sequence[Part], grid: int = 9, most: int = 2_000) -> FloatArray:
    """A grid over the bounding box and at most ``most`` vertices, where the scale is checked.

    The box's corners bound the error of the azimuthal projection (its scale grows with the
    distance from the centre, and the farthest point of a lon/lat box is a corner) and UTM's
    (the scale grows away from the central meridian); the vertices tighten it for other CRSs.
    PROJ's scale factors cost ~10 us a point, hence the cap.
    """
    pts = np.concatenate([r for o, hs in parts for r in (o, *hs)])
    (x0, y0), (x1, y1) = pts.min(axis=0), pts.max(axis=0)
    gx, gy = np.meshgrid(np.linspace(x0, x1, grid), np.linspace(y0, y1, grid))
    step = max(1, len(pts) // most)
    return np.concatenate([pts[::step], np.column_stack([gx.ravel(), gy.ravel()])])
