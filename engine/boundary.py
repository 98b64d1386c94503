"""Regions: validated, oriented polygons with holes.

:func:`make_region` turns raw rings into a :class:`Region` or raises :class:`InvalidBoundary`
saying what is wrong and where (part, ring and input vertex index, and coordinates).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import LinearRing, Polygon

from .errors import InvalidBoundary

__all__ = ["PolygonPart", "Region", "make_region", "signed_area"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Consecutive vertices closer than this fraction of the region's extent are one vertex.
RELATIVE_TOLERANCE = 1e-7
#: Boundary pieces closer than this fraction of the region's extent count as touching (a
#: needle 3e-7 wide whose tip passes 2.4e-8 of the extent from the boundary meshes fine).
MIN_CLEARANCE = 1e-9
#: Largest coordinate accepted: squared lengths of the region must stay finite.
_MAX_COORDINATE = 1e150


def signed_area(ring: FloatArray) -> float:
    """Shoelace area of an open ring: positive when counter-clockwise.

    >>> signed_area(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    0.5
    """
    # Relative to the first vertex: products of large coordinates (UTM metres) cancel badly.
    x, y = ring[:, 0] - ring[0, 0], ring[:, 1] - ring[0, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


@dataclass(frozen=True)
class PolygonPart:
    """One polygon: outer ring counter-clockwise, holes clockwise; rings open (last != first)."""

    outer: FloatArray  #: (n, 2)
    holes: tuple[FloatArray, ...]  #: each (m, 2)

    @property
    def rings(self) -> tuple[FloatArray, ...]:
        return (self.outer, *self.holes)

    @property
    def area(self) -> float:
        return signed_area(self.outer) + sum(signed_area(h) for h in self.holes)

    def to_shapely(self) -> Polygon:
        return Polygon(self.outer, [h for h in self.holes])


@dataclass(frozen=True)
class Region:
    """A valid planar region: one or more disjoint polygons with holes.

    >>> r = make_region([([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], [])])
    >>> r.area, r.n_vertices
    (1.0, 4)
    """

    parts: tuple[PolygonPart, ...]

    @property
    def area(self) -> float:
        return sum(p.area for p in self.parts)

    @property
    def n_vertices(self) -> int:
        return sum(len(r) for p in self.parts for r in p.rings)

    @property
    def rings(self) -> tuple[FloatArray, ...]:
        """All rings of all parts, outer rings counter-clockwise and holes clockwise."""
        return tuple(r for p in self.parts for r in p.rings)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        pts = np.concatenate([p.outer for p in self.parts])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    def to_shapely(self) -> shapely.Geometry:
        polys = [p.to_shapely() for p in self.parts]
        return polys[0] if len(polys) == 1 else shapely.MultiPolygon(polys)


RingInput = ArrayLike
PartInput = tuple[RingInput, Sequence[RingInput]]


def make_region(parts: Sequence[PartInput]) -> Region:
    """Validate and normalise rings into a :class:`Region`.

    ``parts`` is a sequence of ``(outer, holes)``; each ring a sequence of ``[x, y]``, open or
    closed, either winding. Repeated consecutive vertices are dropped.

    >>> make_region([([[0, 0], [1, 1], [1, 0], [0, 1]], [])])
    Traceback (most recent call last):
    ...
    engine.errors.InvalidBoundary: part 0 ring 0 (outer) intersects itself at (0.5, 0.5) near ...
    """
    if len(parts) == 0:
        raise InvalidBoundary("the region has no polygon")
    checked: list[PolygonPart] = []
    polys: list[Polygon] = []
    for ip, (outer, holes) in enumerate(parts):
        rings = [_clean_ring(outer, ip, 0)]
        rings += [_clean_ring(h, ip, ih + 1) for ih, h in enumerate(holes)]
        outer_ring, outer_map = rings[0]
        if signed_area(outer_ring) < 0:
            outer_ring = outer_ring[::-1].copy()
            outer_map = outer_map[::-1].copy()
        hole_rings = []
        for _, (ring, index_map) in enumerate(rings[1:]):
            if signed_area(ring) > 0:
                ring, index_map = ring[::-1].copy(), index_map[::-1].copy()
            hole_rings.append((ring, index_map))
        _check_holes(ip, (outer_ring, outer_map), hole_rings)
        part = PolygonPart(outer_ring, tuple(r for r, _ in hole_rings))
        _check_part_valid(ip, part, [outer_map] + [m for _, m in hole_rings])
        checked.append(part)
        polys.append(part.to_shapely())
    _check_parts_disjoint(polys)
    return Region(tuple(checked))


def _where(part: int, ring: int) -> str:
    return f"part {part} ring {ring} ({'outer' if ring == 0 else 'hole'})"


def _clean_ring(raw: RingInput, part: int, ring: int) -> tuple[FloatArray, IntArray]:
    """Array of an open ring without repeated consecutive vertices, and the input index of each."""
    where = _where(part, ring)
    try:
        arr = np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidBoundary(
            f"{where} is not a list of [x, y] coordinates", part=part, ring=ring
        ) from None
    if arr.ndim != 2 or arr.shape[0] == 0 or arr.shape[1] < 2:
        raise InvalidBoundary(
            f"{where} is not a list of [x, y] coordinates (shape {arr.shape})", part=part, ring=ring
        )
    arr = arr[:, :2]
    bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
    if bad.size:
        v = int(bad[0])
        raise InvalidBoundary(
            f"{where} vertex {v} has a non-finite coordinate", part=part, ring=ring, vertex=v
        )
    # Extents beyond the float range (1e308 on both sides of 0) overflow every later length.
    if np.abs(arr).max() > _MAX_COORDINATE:
        raise InvalidBoundary(
            f"{where} has a coordinate beyond {_MAX_COORDINATE:g} in absolute value",
            part=part, ring=ring, vertex=int(np.abs(arr).max(axis=1).argmax()),
        )  # fmt: skip
    # Consecutive vertices closer than the tolerance are repeats (e.g. a closing vertex written
    # with rounding noise).
    tol = RELATIVE_TOLERANCE * float(np.ptp(arr, axis=0).max())
    index = np.arange(len(arr), dtype=np.int64)
    keep = [0]
    for i in range(1, len(arr)):
        if np.hypot(*(arr[i] - arr[keep[-1]])) > tol:
            keep.append(i)
    arr, index = arr[keep], index[keep]
    if len(arr) > 1 and np.hypot(*(arr[-1] - arr[0])) <= tol:
        arr, index = arr[:-1], index[:-1]
    if len(np.unique(arr, axis=0)) < 3:
        raise InvalidBoundary(f"{where} has fewer than 3 distinct vertices", part=part, ring=ring)
    scale = float(np.ptp(arr, axis=0).max())
    centred = arr - arr.mean(axis=0)
    flat = np.linalg.svd(centred, compute_uv=False)[-1] <= 1e-12 * scale * np.sqrt(len(arr))
    if flat or (abs(signed_area(arr)) <= 1e-14 * scale * scale and LinearRing(arr).is_simple):
        raise InvalidBoundary(f"{where} has zero area", part=part, ring=ring)
    if not LinearRing(arr).is_simple:
        at = _self_intersection(arr)
        v = int(index[_nearest_segment(arr, at)])
        raise InvalidBoundary(
            f"{where} intersects itself at ({at[0]:.6g}, {at[1]:.6g}) near vertex {v}",
            part=part,
            ring=ring,
            vertex=v,
            location=at,
        )
    return arr, index


_REASON_POINT = re.compile(r"\[\s*([-+0-9.eEinfna]+)\s+([-+0-9.eEinfna]+)")


def _reason_point(reason: str) -> tuple[float, float] | None:
    m = _REASON_POINT.search(reason)
    return (float(m.group(1)), float(m.group(2))) if m else None


def _self_intersection(ring: FloatArray) -> tuple[float, float]:
    """A point where a non-simple ring meets itself."""
    at = _reason_point(shapely.is_valid_reason(Polygon(ring)))
    if at is not None:
        return at
    # Shapely names no point (e.g. a repeated vertex): report the first repeated vertex.
    _, first, counts = np.unique(ring, axis=0, return_index=True, return_counts=True)
    dup = first[counts > 1]
    p = ring[int(dup.min())] if dup.size else ring[0]
    return float(p[0]), float(p[1])


def _nearest_segment(ring: FloatArray, at: tuple[float, float]) -> int:
    """Index of the ring vertex that starts the segment nearest to ``at``."""
    a, b = ring, np.roll(ring, -1, axis=0)
    d = b - a
    p = np.asarray(at)
    t = np.clip(((p - a) * d).sum(axis=1) / np.maximum((d * d).sum(axis=1), 1e-300), 0.0, 1.0)
    dist = np.hypot(*(a + t[:, None] * d - p).T)
    return int(np.argmin(dist))


def _first_point(geom: shapely.Geometry) -> tuple[float, float]:
    pt = shapely.get_coordinates(geom)
    return (float(pt[0, 0]), float(pt[0, 1])) if len(pt) else (float("nan"), float("nan"))


def _check_holes(
    part: int,
    outer: tuple[FloatArray, IntArray],
    holes: list[tuple[FloatArray, IntArray]],
) -> None:
    shell = Polygon(outer[0])
    shell_line = LinearRing(outer[0])
    hole_polys = [Polygon(h) for h, _ in holes]
    for ih, ((ring, index_map), hp) in enumerate(zip(holes, hole_polys, strict=True)):
        r = ih + 1
        crossing = hp.boundary.intersection(shell_line)
        if not crossing.is_empty:
            at = _first_point(crossing)
            v = _nearest_segment(ring, at)
            raise InvalidBoundary(
                f"{_where(part, r)} crosses or touches the outer ring "
                f"at ({at[0]:.6g}, {at[1]:.6g})",
                part=part,
                ring=r,
                vertex=int(index_map[v]),
                location=at,
            )
        if not hp.within(shell):
            raise InvalidBoundary(
                f"{_where(part, r)} lies outside the outer ring", part=part, ring=r, vertex=0
            )
    for i in range(len(hole_polys)):
        for j in range(i + 1, len(hole_polys)):
            if hole_polys[i].intersects(hole_polys[j]):
                at = _first_point(hole_polys[i].intersection(hole_polys[j]))
                ring_j, map_j = holes[j]
                v = _nearest_segment(ring_j, at)
                raise InvalidBoundary(
                    f"part {part} holes {i + 1} and {j + 1} touch or overlap at "
                    f"({at[0]:.6g}, {at[1]:.6g})",
                    part=part,
                    ring=j + 1,
                    vertex=int(map_j[v]),
                    location=at,
                )


def _check_part_valid(part: int, poly: PolygonPart, maps: list[IntArray]) -> None:
    """Whatever GEOS finds invalid is reported with the ring and vertex nearest to the problem,
    and so is a vertex closer than :data:`MIN_CLEARANCE` of the region's size to boundary
    it is not joined to (GEOS's minimum clearance): such pieces nearly touch and cannot be
    meshed. Valid polygons with more clearance are accepted whatever their coordinates: snapping
    to a grid and comparing areas refused thin shapes whose area moved by the snap alone."""
    shp = poly.to_shapely()
    nearly = shp.is_valid
    if nearly:
        tol = MIN_CLEARANCE * float(np.ptp(poly.outer, axis=0).max())
        if not shapely.minimum_clearance(shp) < tol:
            return
        line = shapely.get_coordinates(shapely.minimum_clearance_line(shp))
        at: tuple[float, float] | None = (float(line[0, 0]), float(line[0, 1]))
        reason = "Valid Geometry"
    else:
        reason = shapely.is_valid_reason(shp)
        at = _reason_point(reason)
    if at is None:
        raise InvalidBoundary(f"part {part} is not a valid polygon: {reason}", part=part)
    ring, vertex = min(
        ((r, _nearest_segment(ring, at)) for r, ring in enumerate(poly.rings)),
        key=lambda rv: _segment_distance(poly.rings[rv[0]], rv[1], at),
    )
    what = (
        "nearly touches itself (pieces of boundary closer than "
        f"{MIN_CLEARANCE:g} of the region's size)"
        if nearly
        else f"is not valid ({reason.split('[')[0]})"
    )
    raise InvalidBoundary(
        f"{_where(part, ring)} {what} at ({at[0]:.6g}, {at[1]:.6g}) near vertex "
        f"{int(maps[ring][vertex])}",
        part=part,
        ring=ring,
        vertex=int(maps[ring][vertex]),
        location=at,
    )


def _segment_distance(ring: FloatArray, i: int, at: tuple[float, float]) -> float:
    a, b = ring[i], ring[(i + 1) % len(ring)]
    d = b - a
    p = np.asarray(at)
    t = float(np.clip(np.dot(p - a, d) / max(float(np.dot(d, d)), 1e-300), 0.0, 1.0))
    return float(np.hypot(*(a + t * d - p)))


def _check_parts_disjoint(polys: list[Polygon]) -> None:
    if len(polys) < 2:
        return
    tree = shapely.STRtree(polys)
    left, right = tree.query(polys, predicate="intersects")
    for i, j in zip(left.tolist(), right.tolist(), strict=True):
        if i < j:
            at = _first_point(polys[i].boundary.intersection(polys[j].boundary))
            raise InvalidBoundary(
                f"parts {i} and {j} touch or overlap at ({at[0]:.6g}, {at[1]:.6g}); "
                "merge them into one polygon or move them apart",
                part=j,
                location=at,
            )
