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
        tris = shapely.constrained_delaunay_triangles(poly)
        for tri in shapely.get_parts(tris):
            xy = shapely.get_coordinates(tri)[:3]
            try:
                ids = [lookup[(float(x), float(y))] for x, y in xy]
            except KeyError:
                raise MeshingError("cavity triangulation introduced a point") from None
            if _signed_area(xy) < 0:
                ids.reverse()
            triangles.append(ids)
        expected = poly.area
        got = sum(abs(_signed_area(points[t])) for t in triangles[-len(shapely.get_parts(tris)) :])
        if not math.isclose(got, expected, rel_tol=1e-9, abs_tol=1e-12 * max(expected, 1e-300)):
            raise MeshingError("cavity triangulation does not cover the cavity")
    return np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
