"""Lon/lat rings that cross the antimeridian, handled as the small regions they are.

RFC 7946 positions keep longitudes in [-180, 180], so a ring around the 180th meridian jumps by
almost 360 degrees between two consecutive vertices. Read literally it wraps round the globe;
:func:`unwrap_parts` shifts longitudes by multiples of 360 so every ring is continuous and every
ring sits next to the first one, and :func:`normalize_longitudes` brings results back.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import RegionTooLarge

__all__ = ["Part", "crosses_antimeridian", "normalize_longitudes", "unwrap_parts"]

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
