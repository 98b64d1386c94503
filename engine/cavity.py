"""Guaranteed filling of polygonal cavities, the advancing front's last resort.

The cavity is given as directed edges with the unmeshed region on their left (the remaining front).
They are chained into simple rings, grouped into polygons with holes, and triangulated by GEOS's
constrained Delaunay triangulation, adding no points. Quality is left to swapping and smoothing.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import Polygon

from .errors import MeshingError

__all__ = ["fill_cavities", "rings_from_edges"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def rings_from_edges(points: FloatArray, edges: IntArray) -> list[list[int]]:
    """Chain directed edges into closed rings, splitting at vertices used more than once.

    At a vertex with several outgoing edges the ring continues along the first edge clockwise
    from the reversed incoming edge, which keeps the region on the left of each ring.

    >>> pts = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    >>> rings_from_edges(pts, np.array([[0, 1], [1, 2], [2, 3], [3, 0]]))
    [[0, 1, 2, 3]]
    """
    out_edges: dict[int, list[int]] = {}
    for e, (u, _) in enumerate(edges.tolist()):
        out_edges.setdefault(u, []).append(e)
    used = np.zeros(len(edges), dtype=bool)
    rings: list[list[int]] = []
    for e0 in range(len(edges)):
        if used[e0]:
            continue
        ring: list[int] = []
        e = e0
        while not used[e]:
            used[e] = True
            u, v = int(edges[e, 0]), int(edges[e, 1])
            ring.append(u)
            choices = [f for f in out_edges.get(v, []) if not used[f]]
            if not choices:
                break
            if len(choices) == 1:
                e = choices[0]
                continue
            back = math.atan2(points[u, 1] - points[v, 1], points[u, 0] - points[v, 0])

            def clockwise_from_back(f: int, v: int = v, back: float = back) -> float:
                w = int(edges[f, 1])
                ang = math.atan2(points[w, 1] - points[v, 1], points[w, 0] - points[v, 0])
                return (back - ang) % (2 * math.pi) or 2 * math.pi

            e = min(choices, key=clockwise_from_back)
        rings.extend(r for r in _split_at_repeats(ring) if len(r) >= 3)
    return rings


def _split_at_repeats(ring: list[int]) -> list[list[int]]:
    """Split a closed ring that passes a vertex twice into simple rings.

    >>> _split_at_repeats([0, 1, 2, 0, 3, 4])
    [[0, 1, 2], [0, 3, 4]]
    """
    out: list[list[int]] = []
    stack: list[int] = []
    seen: dict[int, int] = {}
    for v in ring:
        if v in seen:
            cut = seen[v]
            loop = stack[cut:]
            out.append(loop)
            for w in loop[1:]:
                del seen[w]
            del stack[cut + 1 :]
        else:
            seen[v] = len(stack)
            stack.append(v)
    out.append(stack)
    return out


def _signed_area(xy: FloatArray) -> float:
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def fill_cavities(points: FloatArray, edges: IntArray) -> IntArray:
    """Triangles (counter-clockwise) that exactly fill the region left of ``edges``.

    Raises :class:`MeshingError` if the edges do not bound a valid region.

    >>> pts = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    >>> len(fill_cavities(pts, np.array([[0, 1], [1, 2], [2, 3], [3, 0]])))
    2
    """
    if len(edges) == 0:
        return np.empty((0, 3), dtype=np.int64)
    rings = rings_from_edges(points, edges)
    shells: list[tuple[list[int], Polygon]] = []
    holes: list[list[int]] = []
    for ring in rings:
        xy = points[ring]
        area = _signed_area(xy)
        if area > 0:
            shells.append((ring, Polygon(xy)))
        elif area < 0:
            holes.append(ring)
    hole_of: dict[int, list[list[int]]] = {i: [] for i in range(len(shells))}
    for ring in holes:
        probe = Polygon(points[ring]).representative_point()
        owners = [i for i, (_, shp) in enumerate(shells) if shp.contains(probe)]
        if not owners:
            raise MeshingError("a cavity hole lies outside every cavity")
        hole_of[min(owners, key=lambda i: shells[i][1].area)].append(ring)
    lookup = {(float(x), float(y)): i for i, (x, y) in enumerate(points.tolist())}
    triangles: list[list[int]] = []
    for i, (shell, _) in enumerate(shells):
        poly = Polygon(points[shell], [points[h] for h in hole_of[i]])
        if not poly.is_valid:
            raise MeshingError(f"cavity is not a valid polygon: {shapely.is_valid_reason(poly)}")
        expected = poly.area
        tris = _constrained_delaunay(points, poly, lookup)
        if tris is None or not _covers(points, tris, expected):
            # GEOS can misjudge slivers (a cavity a few ulps wide): clip ears instead.
            if hole_of[i]:
                raise MeshingError("cavity triangulation does not cover the cavity")
            tris = _ear_clip(points, shell)
            if not _covers(points, tris, expected):
                raise MeshingError("cavity triangulation does not cover the cavity")
        triangles.extend(tris)
    return np.asarray(triangles, dtype=np.int64).reshape(-1, 3)


def _constrained_delaunay(
    points: FloatArray, poly: Polygon, lookup: dict[tuple[float, float], int]
) -> list[list[int]] | None:
    """GEOS's constrained Delaunay triangles of ``poly`` as counter-clockwise vertex ids, or
    None when GEOS made a point of its own."""
    out: list[list[int]] = []
    for tri in shapely.get_parts(shapely.constrained_delaunay_triangles(poly)):
        xy = shapely.get_coordinates(tri)[:3]
        try:
            ids = [lookup[(float(x), float(y))] for x, y in xy]
        except KeyError:
            return None
        if _signed_area(xy) < 0:
            ids.reverse()
        out.append(ids)
    return out


def _covers(points: FloatArray, tris: list[list[int]], expected: float) -> bool:
    """Every triangle is counter-clockwise and non-degenerate, and together they have the
    cavity's area."""
    areas = [_signed_area(points[t]) for t in tris]
    if any(a <= 0.0 for a in areas):
        return False
    # Rounding in the shoelace sums grows with the coordinates' magnitude, not the area: a
    # sliver cavity's area is known only to about eps * extent^2 per triangle.
    xy = points[np.unique(np.asarray(tris))]
    extent2 = float(np.max(np.abs(xy))) ** 2 if len(xy) else 0.0
    tol = 1e-14 * extent2 * len(tris)
    return math.isclose(sum(areas), expected, rel_tol=1e-9, abs_tol=tol)


def _ear_clip(points: FloatArray, ring: list[int]) -> list[list[int]]:
    """Triangulate a simple counter-clockwise ring by clipping its best ear each time.

    An ear is a corner of positive area with no other ring vertex in or on it; the best one has
    the largest smallest-side-to-longest-side ratio. Quadratic per ear, for the small cavities
    the front leaves; the result is checked by the caller.

    >>> pts = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    >>> sorted(sorted(t) for t in _ear_clip(pts, [0, 1, 2, 3]))
    [[0, 1, 3], [1, 2, 3]]
    """
    idx = list(ring)
    out: list[list[int]] = []
    xy = points.tolist()

    def orient(a: int, b: int, c: int) -> float:
        (ax, ay), (bx, by), (cx, cy) = xy[a], xy[b], xy[c]
        return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)

    def shape(a: int, b: int, c: int) -> float:
        sides = [math.dist(xy[a], xy[b]), math.dist(xy[b], xy[c]), math.dist(xy[c], xy[a])]
        return orient(a, b, c) / max(sides) ** 2

    while len(idx) > 3:
        n = len(idx)
        best, best_q = -1, 0.0
        for i in range(n):
            a, b, c = idx[i - 1], idx[i], idx[(i + 1) % n]
            if orient(a, b, c) <= 0.0:
                continue
            blocked = any(
                orient(a, b, p) >= 0.0 and orient(b, c, p) >= 0.0 and orient(c, a, p) >= 0.0
                for p in idx
                if p not in (a, b, c) and xy[p] not in (xy[a], xy[b], xy[c])
            )
            q = shape(a, b, c)
            if not blocked and q > best_q:
                best, best_q = i, q
        if best < 0:
            raise MeshingError("cavity triangulation does not cover the cavity")
        out.append([idx[best - 1], idx[best], idx[(best + 1) % len(idx)]])
        del idx[best]
    out.append(idx)
    return out
