"""Resampling of digitised boundaries: drop vertices the size does not need.

A digitised boundary (survey lines, traced maps) has vertices far closer than the mesh size,
and the mesher keeps every input vertex (:mod:`engine.discretize`). :func:`resample_region`
first simplifies each ring to the local size: vertices at real corners stay, the rest are
thinned with Douglas-Peucker (shapely's ``simplify``) so that the new ring stays within
``tolerance`` of the input; the usual discretisation then splits it to the size field.

Polygons sharing edges (subdomains) are resampled together (:func:`resample_parts`): each
stretch of linework between branch points (where more than two ring segments meet), corners
and ``keep`` points is thinned once, so that the polygons on either side of a shared edge keep
the same vertices on it.

Constraint lines are resampled the same way (:func:`resample_lines`: their ends, corners and
the points given as ``keep`` stay), and ``keep`` points that are ring vertices (the ends of a
named run of a ring, constraint vertices on a ring) stay as corners, so what was drawn on the
input lands on the resampled boundary: :meth:`Resampled.map_path` maps a path of input
vertices (a tag run's) to the vertices of it that stay.

The local size used here is the smallest size asked for anywhere (``size`` within its clamps,
and each refinement's size): the field itself depends on the boundary, so it is built on the
resampled region afterwards.

>>> from engine.boundary import make_region
>>> from engine.params import SizingParams
>>> t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
>>> circle = make_region([(np.c_[10 * np.cos(t), 10 * np.sin(t)], [])])
>>> out = resample_region(circle, SizingParams(size=1.0, resample=True))
>>> out.region.n_vertices < 200, out.max_deviation <= 0.1
(True, True)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from .boundary import PolygonPart, Region, make_region
from .errors import InvalidBoundary
from .params import SizingParams

__all__ = [
    "CORNER_DEG",
    "DEFAULT_TOLERANCE",
    "Resampled",
    "corners",
    "insert_points",
    "resample_constraints",
    "resample_lines",
    "resample_parts",
    "resample_parts_constraints",
    "resample_region",
    "resample_size",
    "resample_tolerance",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: A vertex is a corner when the boundary turns by more than this (degrees) across a window
#: of the local size centred on it: digitising noise, far smaller than the size, does not.
CORNER_DEG = 25.0
#: Default tolerance, as a fraction of the local size.
DEFAULT_TOLERANCE = 0.1
#: Halvings of the tolerance tried when a simplified region is invalid or touches itself.
_RETRIES = 4


@dataclass(frozen=True)
class Resampled:
    """A resampled region and how far its boundary is from the input's."""

    region: Region
    max_deviation: float  #: largest distance from an input vertex to the resampled boundary
    tolerance: float  #: the tolerance that gave a valid region (0 when the input was kept)
    vertices_before: int
    vertices_after: int

    def map_path(self, path: ArrayLike) -> FloatArray:
        """The vertices of ``path`` (input ring vertices, in order) that are vertices of the
        resampled region: a run between two kept vertices, as the resampled ring has it.

        >>> from engine.boundary import make_region
        >>> square = make_region([([[0, 0], [0.5, 0.001], [1, 0], [1, 1], [0, 1]], [])])
        >>> out = resample_region(square, SizingParams(size=1.0, resample=True), keep=[[1, 0]])
        >>> out.map_path([[0, 0], [0.5, 0.001], [1, 0], [1, 1]]).tolist()
        [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]
        """
        xy = np.asarray(path, dtype=np.float64)[:, :2]
        kept = {tuple(p) for r in self.region.rings for p in r.tolist()}
        return xy[[tuple(p) in kept for p in xy.tolist()]]

    def summary(self) -> dict[str, float | int]:
        """The figures a result's ``summary["boundary"]`` carries."""
        return {
            "resampled": True,
            "max_deviation": self.max_deviation,
            "tolerance": self.tolerance,
            "vertices_before": self.vertices_before,
            "vertices_after": self.vertices_after,
        }


def resample_size(sizing: SizingParams) -> float:
    """The local size resampling works to: the smallest size asked for anywhere.

    >>> resample_size(SizingParams(size=2.0, size_max=1.5))
    1.5
    """
    h = sizing.size
    if sizing.size_max is not None:
        h = min(h, sizing.size_max)
    if sizing.size_min is not None:
        h = max(h, sizing.size_min)
    return min([h, *(r.size for r in sizing.refinements)])


def _arc(ring: FloatArray) -> tuple[FloatArray, float]:
    seg = np.hypot(*(np.roll(ring, -1, axis=0) - ring).T)
    return np.concatenate(([0.0], np.cumsum(seg)[:-1])), float(seg.sum())


def _at(ring: FloatArray, s_of: FloatArray, perimeter: float, s: FloatArray) -> FloatArray:
    """Points at arc lengths ``s`` (any real, taken around the closed ring)."""
    closed_s = np.append(s_of, perimeter)
    closed = np.vstack([ring, ring[:1]])
    s = np.mod(s, perimeter)
    return np.c_[np.interp(s, closed_s, closed[:, 0]), np.interp(s, closed_s, closed[:, 1])]


def _at_open(line: FloatArray, s_of: FloatArray, s: FloatArray) -> FloatArray:
    """Points at arc lengths ``s`` along the open ``line`` (clamped to its ends)."""
    return np.c_[np.interp(s, s_of, line[:, 0]), np.interp(s, s_of, line[:, 1])]


def corners(ring: FloatArray, window: float, closed: bool = True) -> IntArray:
    """Indices of the vertices of ``ring`` (an open line when not ``closed``: its ends do not
    count) where it turns by more than :data:`CORNER_DEG` across ``window`` (centred on the
    vertex); of those within the window of each other, the sharpest.

    >>> corners(np.array([[0.0, 0], [1, 0], [2, 0], [2, 1], [2, 2], [0, 2]]), 0.5).tolist()
    [0, 2, 4, 5]
    >>> corners(np.array([[0.0, 0], [1, 0], [2, 0], [2, 1], [2, 2], [0, 2]]), 0.5, False).tolist()
    [2, 4]
    """
    if closed:
        s_of, perimeter = _arc(ring)
        half = min(0.5 * window, perimeter / 8.0)
        back = _at(ring, s_of, perimeter, s_of - half)
        fwd = _at(ring, s_of, perimeter, s_of + half)
    else:
        s_of = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(ring, axis=0).T))))
        perimeter = float(s_of[-1])
        half = min(0.5 * window, perimeter / 8.0)
        back, fwd = _at_open(ring, s_of, s_of - half), _at_open(ring, s_of, s_of + half)
    d_in, d_out = ring - back, fwd - ring
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    turn = np.degrees(np.abs(np.arctan2(cross, (d_in * d_out).sum(axis=1))))
    sharp = turn > CORNER_DEG
    if not closed:  # the ends are kept anyway; near them the window is cut short
        sharp &= (s_of >= half) & (s_of <= perimeter - half)
    if not sharp.any():
        return np.empty(0, dtype=np.int64)
    # Of the vertices within the window of each other, the sharpest (the vertices next to a
    # corner see it inside their window too, turning less).
    if closed:
        closed_s = np.r_[s_of - perimeter, s_of, s_of + perimeter]
        turns = np.r_[turn, turn, turn]
    else:
        closed_s, turns = s_of, turn
    picked = []
    for i in np.flatnonzero(sharp):
        lo, hi = np.searchsorted(closed_s, [s_of[i] - half, s_of[i] + half], side="left")
        hi = min(hi, len(turns) - 1)
        if turn[i] >= turns[lo : hi + 1].max():
            picked.append(i)
    return np.sort(np.asarray(picked, dtype=np.int64))


def _kept(xy: FloatArray, keep: FloatArray) -> IntArray:
    """Indices of the vertices of ``xy`` that are points of ``keep``."""
    if not len(keep):
        return np.empty(0, dtype=np.int64)
    wanted = {tuple(p) for p in keep.tolist()}
    return np.flatnonzero([tuple(p) in wanted for p in xy.tolist()]).astype(np.int64)


def _simplify_ring(
    ring: FloatArray, window: float, tolerance: float, keep: FloatArray
) -> FloatArray:
    """``ring`` thinned between its corners and its ``keep`` points (kept) to within
    ``tolerance``."""
    anchors = np.union1d(corners(ring, window), _kept(ring, keep))
    if len(anchors) < 3:  # a smooth ring: anchor it at thirds of its length as well
        s_of, perimeter = _arc(ring)
        thirds = np.searchsorted(s_of, perimeter * np.arange(3) / 3.0)
        anchors = np.unique(np.r_[anchors, np.minimum(thirds, len(ring) - 1)])
    if len(anchors) >= len(ring):
        return ring
    bounds = np.r_[anchors, anchors[0] + len(ring)]
    doubled = np.vstack([ring, ring])
    pairs = pairwise(bounds)
    lines = np.array([shapely.LineString(doubled[a : b + 1]) for a, b in pairs])
    thinned = shapely.simplify(lines, tolerance, preserve_topology=False)
    pieces = shapely.get_coordinates(thinned)
    counts = shapely.get_num_coordinates(thinned)
    last = np.cumsum(counts) - 1  # each piece's end is the next one's start
    out = np.delete(pieces, last, axis=0)
    return ring if len(out) < 3 else out


def _deviation(before: FloatArray, after: FloatArray) -> float:
    """Largest distance from a vertex of ``before`` to the closed ring ``after`` (the
    vertices of ``after`` are vertices of ``before``, so the other direction is 0)."""
    return float(shapely.distance(shapely.points(before), shapely.linearrings(after)).max())


def resample_region(region: Region, sizing: SizingParams, keep: ArrayLike = ()) -> Resampled:
    """``region`` with each ring re-discretised to the local size (:func:`resample_size`):
    corners and the ring vertices that are ``keep`` points kept, every input vertex within the
    tolerance (``sizing.resample_tolerance``, by default :data:`DEFAULT_TOLERANCE` of the size)
    of the new boundary. When the simplified region is not valid (rings crossing or touching),
    the tolerance is halved and tried again; after :data:`_RETRIES` halvings the input is
    kept."""
    h = resample_size(sizing)
    tolerance = resample_tolerance(sizing)
    fixed = np.asarray(keep, dtype=np.float64).reshape(-1, 2)
    before = region.n_vertices
    for _ in range(_RETRIES + 1):
        parts = [
            [_simplify_ring(r, h, tolerance, fixed) for r in part.rings] for part in region.parts
        ]
        try:
            simplified = make_region([(rings[0], rings[1:]) for rings in parts])
        except InvalidBoundary:
            tolerance *= 0.5
            continue
        deviation = max(
            _deviation(a, b)
            for part, rings in zip(region.parts, parts, strict=True)
            for a, b in zip(part.rings, rings, strict=True)
        )
        return Resampled(simplified, deviation, tolerance, before, simplified.n_vertices)
    return Resampled(region, 0.0, 0.0, before, before)


def resample_tolerance(sizing: SizingParams) -> float:
    """The largest distance resampling may move the boundary: ``sizing.resample_tolerance``,
    by default :data:`DEFAULT_TOLERANCE` of :func:`resample_size`."""
    given = sizing.resample_tolerance
    return DEFAULT_TOLERANCE * resample_size(sizing) if given is None else given


def resample_lines(
    lines: Sequence[FloatArray], window: float, tolerance: float, keep: ArrayLike = ()
) -> tuple[list[FloatArray], float]:
    """Open polylines (constraint lines) thinned as rings are: their ends, corners (turning
    by more than :data:`CORNER_DEG` across ``window``) and ``keep`` points stay, the rest within
    ``tolerance``; and the largest distance of an input vertex from its thinned line.

    >>> t = np.linspace(0, 1, 201)
    >>> wiggly = np.c_[t, 1e-4 * np.sin(300 * t)]
    >>> out, deviation = resample_lines([wiggly], 0.2, 0.01, keep=[wiggly[100]])
    >>> len(out[0]), out[0][1].tolist() == wiggly[100].tolist(), deviation < 1e-3
    (3, True, True)
    """
    fixed = np.asarray(keep, dtype=np.float64).reshape(-1, 2)
    out, deviation = [], 0.0
    for xy in lines:
        xy = np.asarray(xy, dtype=np.float64)[:, :2]
        anchors = np.union1d(np.r_[0, len(xy) - 1, corners(xy, window, False)], _kept(xy, fixed))
        pieces = [shapely.LineString(xy[a : b + 1]) for a, b in pairwise(anchors.tolist())]
        thinned = shapely.simplify(np.array(pieces), tolerance, preserve_topology=False)
        coords = [shapely.get_coordinates(p) for p in thinned]
        line = np.concatenate([coords[0], *(c[1:] for c in coords[1:])]) if coords else xy
        deviation = max(
            deviation, float(shapely.distance(shapely.points(xy), shapely.LineString(line)).max())
        )
        out.append(line)
    return out, deviation


def resample_constraints(
    region: Region, sizing: SizingParams, geoms: Sequence[shapely.Geometry], keep: ArrayLike = ()
) -> tuple[Resampled, list[shapely.Geometry], float]:
    """Resample ``region`` and the constraint lines of ``geoms`` together: every constraint
    vertex and ``keep`` point that is a ring vertex stays one, vertices shared by constraint
    lines and the points where lines cross each other or a ring stay, a constraint vertex that
    lay on a ring (between its vertices) is put on the resampled ring. Returns the resampled
    region, the constraints and the largest distance of a constraint line's vertex from its
    resampled line."""
    given = np.asarray(keep, dtype=np.float64).reshape(-1, 2)
    resampled = resample_region(region, sizing, keep=np.concatenate([_vertices(geoms), given]))
    tolerance = resampled.tolerance or resample_tolerance(sizing)
    thinned, deviation = _thin_constraints(
        region, resampled.region, geoms, given, resample_size(sizing), tolerance
    )
    return resampled, thinned, deviation


def resample_parts_constraints(
    parts: Sequence[PolygonPart],
    sizings: Sequence[SizingParams],
    geoms: Sequence[shapely.Geometry],
    keep: ArrayLike = (),
) -> tuple[Resampled, list[shapely.Geometry], float]:
    """Subdomains (:func:`resample_parts`) and the constraint lines of ``geoms`` resampled
    together as :func:`resample_constraints` does for one region: the lines' ends, corners,
    junctions, crossings with each other and with every ring (interfaces included) stay, and
    the lines are thinned to the smallest of the polygons' sizes and tolerances."""
    given = np.asarray(keep, dtype=np.float64).reshape(-1, 2)
    resampled = resample_parts(parts, sizings, keep=np.concatenate([_vertices(geoms), given]))
    tolerance = resampled.tolerance or min(resample_tolerance(s) for s in sizings)
    window = min(resample_size(s) for s in sizings)
    thinned, deviation = _thin_constraints(
        Region(tuple(parts)), resampled.region, geoms, given, window, tolerance
    )
    return resampled, thinned, deviation


def _vertices(geoms: Sequence[shapely.Geometry]) -> FloatArray:
    return np.concatenate([np.empty((0, 2)), *(shapely.get_coordinates(g) for g in geoms)])


def insert_points(xy: FloatArray, extra: FloatArray, tol: float, closed: bool) -> FloatArray:
    """``xy`` (a ring when ``closed``, else an open line) with the points of ``extra`` that
    lie (within ``tol``) inside its segments inserted in order; each on its first segment.

    >>> insert_points(np.array([[0.0, 0], [2, 0], [2, 1]]), np.array([[1.0, 0]]), 1e-9, False)
    array([[0., 0.],
           [1., 0.],
           [2., 0.],
           [2., 1.]])
    """
    a = xy if closed else xy[:-1]
    b = np.roll(xy, -1, axis=0) if closed else xy[1:]
    segs = shapely.linestrings(np.stack([a, b], axis=1))
    pi, si = shapely.STRtree(segs).query(shapely.points(extra), "dwithin", tol)
    d = b[si] - a[si]
    t = ((extra[pi] - a[si]) * d).sum(axis=1) / (d * d).sum(axis=1)
    inner = (t > 1e-12) & (t < 1 - 1e-12)
    pi, si, t = pi[inner], si[inner], t[inner]
    first = np.unique(pi, return_index=True)[1]  # a point near two segments goes in once
    pi, at = pi[first], si[first] + t[first]
    order = np.argsort(np.r_[np.arange(len(xy), dtype=np.float64), at], kind="stable")
    return np.concatenate([xy, extra[pi]])[order]


def _crossings(lines: Sequence[FloatArray], rings: Sequence[FloatArray]) -> list[FloatArray]:
    """For each line, the points where it meets another line or a ring (each point computed
    once, so both lines at a crossing get the same one)."""
    shapes = np.array([shapely.LineString(xy) for xy in lines])
    linework = shapely.union_all([shapely.LinearRing(r) for r in rings])
    out = [shapely.get_coordinates(shapely.intersection(g, linework)) for g in shapes]
    left, right = shapely.STRtree(shapes).query(shapes, predicate="intersects")
    for i, j in zip(left.tolist(), right.tolist(), strict=True):
        if i < j:
            xy = shapely.get_coordinates(shapely.intersection(shapes[i], shapes[j]))
            out[i], out[j] = np.r_[out[i], xy], np.r_[out[j], xy]
    return out


def _thin_constraints(
    before: Region,
    after: Region,
    geoms: Sequence[shapely.Geometry],
    given: FloatArray,
    window: float,
    tolerance: float,
) -> tuple[list[shapely.Geometry], float]:
    """The constraints of ``geoms`` with their lines thinned (see :func:`resample_constraints`)
    for the rings of ``before`` resampled to ``after``; and the lines' largest deviation."""
    vertices = _vertices(geoms)
    old = shapely.union_all([shapely.LinearRing(r) for r in before.rings])
    new = shapely.union_all([shapely.LinearRing(r) for r in after.rings])
    x0, y0, x1, y1 = before.bounds
    on = 1e-9 * max(x1 - x0, y1 - y0)
    lines = [
        shapely.get_coordinates(part)
        for g in geoms
        if "Line" in g.geom_type
        for part in getattr(g, "geoms", [g])
    ]
    # Vertices of more than one line (junctions), crossings and vertices on a ring stay.
    seen = np.concatenate([np.empty((0, 2)), *(np.unique(xy, axis=0) for xy in lines)])
    uniq, count = np.unique(seen, axis=0, return_counts=True)
    touching = vertices[shapely.distance(old, shapely.points(vertices)) < on]
    crossing = _crossings(lines, before.rings) if lines else []
    lines = [insert_points(xy, c, on, False) for xy, c in zip(lines, crossing, strict=True)]
    joints = np.concatenate([uniq[count > 1], touching, given, *crossing])
    thinned, deviation = resample_lines(lines, window, tolerance, keep=joints)

    def onto_rings(xy: FloatArray) -> FloatArray:
        pts = shapely.points(xy)
        moved = (shapely.distance(old, pts) < on) & (shapely.distance(new, pts) > on)
        if moved.any():
            xy = xy.copy()
            at = shapely.line_locate_point(new, pts[moved])
            xy[moved] = shapely.get_coordinates(shapely.line_interpolate_point(new, at))
        return xy

    out, k = [], 0
    for g in geoms:
        if "Line" in g.geom_type:
            n = len(getattr(g, "geoms", [g]))
            parts = [shapely.LineString(onto_rings(xy)) for xy in thinned[k : k + n]]
            k += n
            out.append(parts[0] if g.geom_type == "LineString" else shapely.MultiLineString(parts))
        else:
            out.append(shapely.transform(g, onto_rings))
    return out, deviation


_Key = tuple[float, ...]


def _piece_key(piece: FloatArray) -> tuple[_Key, bool]:
    """The same key for a stretch of linework whichever way it is walked, and whether this
    walk is the reverse of the key's direction."""
    fwd = tuple(piece[[0, 1, -1]].ravel().tolist())
    rev = tuple(piece[[-1, -2, 0]].ravel().tolist())
    return min(fwd, rev), rev < fwd


def _branch_points(rings: Sequence[FloatArray]) -> FloatArray:
    """Vertices met by other than two distinct segments of ``rings``: where shared linework
    starts or ends, and where polygons meet at a point."""
    segs = np.concatenate([np.stack([r, np.roll(r, -1, axis=0)], axis=1) for r in rings])
    flat = segs.reshape(-1, 4)
    swap = (flat[:, 0] > flat[:, 2]) | ((flat[:, 0] == flat[:, 2]) & (flat[:, 1] > flat[:, 3]))
    flat[swap] = flat[swap][:, [2, 3, 0, 1]]
    ends = np.unique(flat, axis=0).reshape(-1, 2)
    xy, count = np.unique(ends, axis=0, return_counts=True)
    return xy[count != 2]


def _anchors(
    rings: Sequence[FloatArray], windows: Sequence[float], keep: FloatArray
) -> set[tuple[float, ...]]:
    """Vertices every ring keeps: branch points, each ring's corners, ``keep``; and of a ring
    with fewer than three, points at thirds of its length (in every ring holding them)."""
    fixed = np.concatenate([_branch_points(rings), keep])
    for ring, window in zip(rings, windows, strict=True):
        fixed = np.concatenate([fixed, ring[corners(ring, window)]])
    out = {tuple(p) for p in fixed.tolist()}
    for ring in rings:
        if len(_kept(ring, np.array(sorted(out)).reshape(-1, 2))) < 3:
            s_of, perimeter = _arc(ring)
            thirds = np.searchsorted(s_of, perimeter * np.arange(3) / 3.0)
            # By vertex count too, when one segment spans more than a third.
            at = np.r_[np.minimum(thirds, len(ring) - 1), len(ring) * np.arange(3) // 3]
            out |= {tuple(p) for p in ring[at].tolist()}
    return out


def resample_parts(
    parts: Sequence[PolygonPart], sizings: Sequence[SizingParams], keep: ArrayLike = ()
) -> Resampled:
    """Polygons that may share edges (subdomains), each ring re-discretised as
    :func:`resample_region` does with its part's sizing (``sizings[i]``), every shared stretch
    thinned once (to the smaller tolerance of its polygons) so both keep the same vertices on
    it; branch points, corners and ``keep`` points stay. The polygons must be noded (a vertex
    of one on another's edge is a vertex of both). When a polygon comes out invalid or
    overlapping another, the tolerances are halved and tried again; after :data:`_RETRIES`
    halvings the input is kept. The result's region holds the touching parts (not validated
    as one region).

    >>> from engine.boundary import make_region
    >>> t = np.linspace(0, 1, 401)
    >>> left = make_region([(np.r_[[[0, 1], [0, 0]], np.c_[t, 0.01 * np.sin(40 * t)]], [])])
    >>> right = make_region([(np.r_[np.c_[t, 0.01 * np.sin(40 * t)][::-1], [[1, -1]]], [])])
    >>> out = resample_parts(
    ...     [left.parts[0], right.parts[0]], [SizingParams(0.25, resample=True)] * 2
    ... )
    >>> a, b = (set(map(tuple, p.outer.tolist())) for p in out.region.parts)
    >>> len(a & b) < 100, out.vertices_after < 200, out.max_deviation <= 0.025
    (True, True, True)
    """
    rings = [r for p in parts for r in p.rings]
    owner = [i for i, p in enumerate(parts) for _ in p.rings]
    windows = [resample_size(sizings[i]) for i in owner]
    fixed = _anchors(rings, windows, np.asarray(keep, dtype=np.float64).reshape(-1, 2))
    # Each ring's pieces between its anchors, each piece keyed the same from either side.
    walks: list[list[tuple[_Key, bool]]] = []
    pieces: dict[_Key, FloatArray] = {}
    tolerance: dict[_Key, float] = {}
    for ring, i in zip(rings, owner, strict=True):
        at = np.flatnonzero([tuple(p) in fixed for p in ring.tolist()])
        doubled = np.vstack([ring, ring])
        walk = []
        for a, b in pairwise(np.r_[at, at[0] + len(ring)].tolist()):
            key, backwards = _piece_key(doubled[a : b + 1])
            pieces[key] = doubled[a : b + 1][::-1] if backwards else doubled[a : b + 1]
            tolerance[key] = min(tolerance.get(key, np.inf), resample_tolerance(sizings[i]))
            walk.append((key, backwards))
        walks.append(walk)
    keys = list(pieces)
    lines = np.array([shapely.LineString(pieces[k]) for k in keys])
    scale = 1.0
    before = sum(len(r) for r in rings)
    for _ in range(_RETRIES + 1):
        tol = np.array([tolerance[k] for k in keys]) * scale
        simple = shapely.simplify(lines, tol, preserve_topology=False)
        thinned = {k: shapely.get_coordinates(g) for k, g in zip(keys, simple, strict=True)}
        out = [
            np.concatenate([(thinned[k][::-1] if back else thinned[k])[:-1] for k, back in w])
            for w in walks
        ]
        new, k = [], 0
        for p in parts:
            new.append(PolygonPart(out[k], tuple(out[k + 1 : k + len(p.rings)])))
            k += len(p.rings)
        polys = [q.to_shapely() for q in new]
        area = sum(q.area for q in polys)
        try:
            for q in new:
                make_region([(q.outer, list(q.holes))])
        except InvalidBoundary:
            scale *= 0.5
            continue
        if abs(shapely.union_all(polys).area - area) > 1e-9 * area:
            scale *= 0.5
            continue
        deviation = max(_deviation(a, b) for a, b in zip(rings, out, strict=True))
        after = sum(len(r) for r in out)
        return Resampled(Region(tuple(new)), deviation, float(tol.min()), before, after)
    return Resampled(Region(tuple(parts)), 0.0, 0.0, before, before)
