"""Lon/lat rings that cross the antimeridian, handled as the small regions they are.

RFC 7946 positions keep longitudes in [-180, 180], so a ring around the 180th meridian jumps by
almost 360 degrees between two consecutive vertices. Read literally it wraps round the globe;
:func:`unwrap_parts` shifts longitudes by multiples of 360 so every ring is continuous and every
ring sits next to the first one, and :func:`normalize_longitudes` brings results back.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
import shapely.affinity
from numpy.typing import ArrayLike, NDArray

from .errors import RegionTooLarge

__all__ = [
    "Part",
    "crosses_antimeridian",
    "normalize_longitudes",
    "split_at_antimeridian",
    "unwrap_parts",
]

FloatArray = NDArray[np.float64]
#: One polygon: its outer ring and its holes, each an (n, 2) array of lon/lat.
Part = tuple[FloatArray, list[FloatArray]]


def _unwrap_ring(ring: FloatArray, where: str) -> FloatArray:
    lon = np.unwrap(np.append(ring[:, 0], ring[0, 0]), period=360.0)
    # Closed again only when the ring goes round no pole: a ring round a pole gains 360 degrees.
    if abs(lon[-1] - lon[0]) > 1e-9:
        raise RegionTooLarge(
            f"{where} goes all the way round a pole; a region containing a pole cannot be meshed "
            "as lon/lat: send it in a polar projected CRS (e.g. EPSG:3413 or EPSG:3031)"
        )
    return np.column_stack([lon[:-1], ring[:, 1]])


def unwrap_parts(parts: Sequence[tuple[ArrayLike, Sequence[ArrayLike]]]) -> list[Part]:
    """Lon/lat rings with continuous longitudes, every ring next to the first one.

    Consecutive vertices more than 180 degrees of longitude apart are taken to cross the
    antimeridian. The first outer ring's centre stays within [-180, 180]; other longitudes may
    leave that range. Raises :class:`RegionTooLarge` for a ring round a pole.

    >>> [(o[:, 0].tolist(), h) for o, h in unwrap_parts([([[179, 0], [-179, 0], [-179, 1]], [])])]
    [([179.0, 181.0, 181.0], [])]
    """
    out: list[Part] = []
    ref: float | None = None
    for ip, (outer, holes) in enumerate(parts):
        rings = []
        for ir, ring in enumerate([outer, *holes]):
            xy = np.asarray(ring, dtype=np.float64)[:, :2]
            xy = _unwrap_ring(xy, f"part {ip} ring {ir}")
            centre = 0.5 * (float(xy[:, 0].min()) + float(xy[:, 0].max()))
            if ref is None:
                # Keep the first ring's centre in [-180, 180] (an input may start at 190).
                ref = centre - 360.0 * round(centre / 360.0)
            xy[:, 0] += 360.0 * round((ref - centre) / 360.0)
            rings.append(xy)
        out.append((rings[0], rings[1:]))
    return out


def crosses_antimeridian(parts: Sequence[tuple[ArrayLike, Sequence[ArrayLike]]]) -> bool:
    """Whether the region, unwrapped, reaches past 180 or -180 degrees of longitude.

    >>> crosses_antimeridian([([[179, 0], [-179, 0], [-179, 1]], [])])
    True
    >>> crosses_antimeridian([([[0, 0], [1, 0], [1, 1]], [])])
    False
    """
    lon = np.concatenate([r[:, 0] for o, hs in unwrap_parts(parts) for r in (o, *hs)])
    return bool(lon.min() < -180.0 or lon.max() > 180.0)


def normalize_longitudes(lonlat: ArrayLike) -> FloatArray:
    """A copy of (n, 2) lon/lat positions with longitudes brought into [-180, 180].

    >>> normalize_longitudes([[181.0, 5.0], [-190.0, 0.0], [180.0, 1.0]]).tolist()
    [[-179.0, 5.0], [170.0, 0.0], [180.0, 1.0]]
    """
    xy = np.array(lonlat, dtype=np.float64, ndmin=2)
    # round() leaves +-180 as they are (180/360 rounds to even, 0) and folds everything else in.
    xy[:, 0] -= 360.0 * np.round(xy[:, 0] / 360.0)
    return xy


def split_at_antimeridian(outer: ArrayLike, holes: Sequence[ArrayLike] = ()) -> list[Part]:
    """A lon/lat polygon as RFC 7946 wants it written: cut at 180 degrees when it crosses.

    Returns the polygon when it does not cross, else its pieces east
    and west of the antimeridian, each within [-180, 180]. For writing results (e.g. a mesh's
    triangles as GeoJSON) whose points :meth:`~service.geo.crs.Projection.inverse` gave.

    >>> pieces = split_at_antimeridian([[179, 0], [-179, 0], [-179, 1]])
    >>> sorted((float(o[:, 0].min()), float(o[:, 0].max())) for o, _ in pieces)
    [(-180.0, -179.0), (179.0, 180.0)]
    """
    ((ring, inner),) = unwrap_parts([(outer, holes)])
    lon = np.concatenate([r[:, 0] for r in (ring, *inner)])
    polygon = shapely.Polygon(ring, inner)
    if lon.min() >= -180.0 and lon.max() <= 180.0:
        return [_oriented(polygon)]
    # The first ring's centre is within [-180, 180], so the polygon overhangs on one side only.
    if lon.max() > 180.0:
        windows = [((-540.0, 180.0), 0.0), ((180.0, 540.0), -360.0)]
    else:
        windows = [((-180.0, 540.0), 0.0), ((-540.0, -180.0), 360.0)]
    pieces: list[Part] = []
    for (lo, hi), move in windows:
        clipped = shapely.clip_by_rect(polygon, lo, -90.0, hi, 90.0)
        for piece in getattr(clipped, "geoms", [clipped]):
            if not isinstance(piece, shapely.Polygon) or piece.is_empty or piece.area == 0:
                continue
            pieces.append(_oriented(shapely.affinity.translate(piece, move)))
    return pieces


def _oriented(polygon: shapely.Polygon) -> Part:
    """Open rings, exterior counter-clockwise and holes clockwise (RFC 7946's right-hand rule)."""
    polygon = shapely.orient_polygons(polygon)
    holes = [np.asarray(h.coords)[:-1] for h in polygon.interiors]
    return np.asarray(polygon.exterior.coords)[:-1], holes
