"""Boundary tags and regions: which input ring (or named run of one) each boundary edge of a
mesh came from, and which polygon each triangle lies in.

Tags are found geometrically on the final mesh: every boundary node lies on an input segment
(discretisation keeps input vertices and splits segments, swapping never flips a boundary edge
and smoothing never moves a boundary node), so the midpoint of a boundary edge lies on exactly one
input segment. This needs nothing from the mesher and holds whatever discretised the rings.

>>> from engine.boundary import make_region
>>> from engine.mesh import Mesh
>>> region = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
>>> mesh = Mesh(np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]]), np.array([[0, 1, 2], [0, 2, 3]]))
>>> tagged = tag_mesh(mesh, region, Tagging(runs=(TagRun("inlet", [[0, 1], [0, 0]]),)))
>>> tagged.tags, tagged.line_tag.tolist(), tagged.regions, tagged.region.tolist()
({'outer': 1, 'inlet': 2}, [1, 1, 1, 2], {'region-0': 1}, [1, 1])
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from .boundary import Region
from .errors import EngineError
from .mesh import Mesh

__all__ = ["MeshTags", "TagRun", "Tagging", "default_tag_names", "interface_edges", "tag_mesh"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: A boundary edge lies on a segment when its midpoint is this close, relative to the extent.
_ON_SEGMENT = 1e-7


class InvalidTag(EngineError, ValueError):
    """A tag run that names no boundary edge of the mesh (``run`` is its index)."""

    def __init__(self, message: str, *, run: int) -> None:
        super().__init__(message)
        self.run = run


@dataclass(frozen=True)
class TagRun:
    """A named run of boundary: every boundary edge lying on the polyline ``path``."""

    name: str
    path: ArrayLike  #: (k, 2) input vertices along a ring, k >= 2

    def line(self) -> shapely.LineString:
        return shapely.LineString(np.asarray(self.path, dtype=np.float64)[:, :2])


@dataclass(frozen=True)
class Tagging:
    """How to name boundaries and regions; the defaults name every ring."""

    #: One name per part of the region (``None`` or missing: ``region-N``).
    names: Sequence[str | None] = ()
    #: Named runs; a later run wins where runs overlap.
    runs: Sequence[TagRun] = ()


@dataclass(frozen=True)
class MeshTags:
    """Tagged lines and triangle regions of a mesh; ids are 1-based (0 is no tag)."""

    #: (e, 2) tagged mesh edges: the boundary (mesh on the left), then interfaces between regions
    lines: IntArray
    line_tag: IntArray  #: (e,) the tag id of each line
    tags: dict[str, int]  #: tag name -> id
    region: IntArray  #: (m,) the region id of each triangle
    regions: dict[str, int]  #: region name -> id
    fixed: BoolArray = field(repr=False)  #: (n,) nodes no smoother may move (on a line)


def region_names(region: Region, tagging: Tagging) -> list[str]:
    """The name of each part: given, else ``region-N``."""
    given = list(tagging.names) + [None] * len(region.parts)
    return [given[i] or f"region-{i}" for i in range(len(region.parts))]


def default_tag_names(region: Region, tagging: Tagging) -> list[str]:
    """The default tag of each ring (``Region.rings`` order): ``outer`` / ``hole-K``, prefixed
    with ``<region name>/`` when the region has several parts or its part is named.

    >>> from engine.boundary import make_region
    >>> r = make_region([([[0, 0], [4, 0], [4, 4], [0, 4]], [[[1, 1], [2, 1], [2, 2]]])])
    >>> default_tag_names(r, Tagging()), default_tag_names(r, Tagging(names=["lake"]))
    (['outer', 'hole-1'], ['lake/outer', 'lake/hole-1'])
    """
    names = region_names(region, tagging)
    prefixed = len(region.parts) > 1 or any(tagging.names)
    out = []
    for part, name in zip(region.parts, names, strict=True):
        prefix = f"{name}/" if prefixed else ""
        out += [f"{prefix}{'outer' if k == 0 else f'hole-{k}'}" for k in range(len(part.rings))]
    return out


def _ring_segments(region: Region) -> tuple[shapely.STRtree, IntArray]:
    """A tree of every ring segment, and the ring of each."""
    segs, ring_of = [], []
    for r, ring in enumerate(region.rings):
        a, b = ring, np.roll(ring, -1, axis=0)
        segs.append(shapely.linestrings(np.stack([a, b], axis=1)))
        ring_of.append(np.full(len(ring), r, dtype=np.int64))
    return shapely.STRtree(np.concatenate(segs)), np.concatenate(ring_of)


def triangle_regions(mesh: Mesh, region: Region) -> IntArray:
    """The 1-based part of ``region`` holding each triangle's centroid (0: none)."""
    c = mesh.points[mesh.triangles].mean(axis=1)
    out = np.zeros(mesh.n_triangles, dtype=np.int64)
    for i, part in enumerate(region.parts):
        poly = part.to_shapely()
        shapely.prepare(poly)
        out[(out == 0) & shapely.contains_xy(poly, c[:, 0], c[:, 1])] = i + 1
    return out


def interface_edges(triangles: IntArray, region: IntArray) -> tuple[IntArray, IntArray]:
    """Edges (k, 2) between triangles of different regions, and the two regions (k, 2), each
    pair sorted.

    >>> tri = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4]])
    >>> [a.tolist() for a in interface_edges(tri, np.array([1, 1, 2]))]
    [[[0, 3]], [[1, 2]]]
    """
    sides = np.stack([triangles[:, [1, 2]], triangles[:, [2, 0]], triangles[:, [0, 1]]], axis=1)
    sides = np.sort(sides.reshape(-1, 2), axis=1)
    owner = np.repeat(region, 3)
    order = np.lexsort((sides[:, 1], sides[:, 0]))
    s, o = sides[order], owner[order]
    cross = (s[1:] == s[:-1]).all(axis=1) & (o[1:] != o[:-1])
    pairs = np.sort(np.stack([o[:-1][cross], o[1:][cross]], axis=1), axis=1)
    return s[1:][cross].astype(np.int64), pairs.astype(np.int64)


def tag_mesh(
    mesh: Mesh,
    region: Region,
    tagging: Tagging | None = None,
    lines: Mapping[str, ArrayLike] | None = None,
    pinned: ArrayLike = (),
) -> MeshTags:
    """Tag every boundary edge of ``mesh`` (a mesh of ``region``) and give each triangle its
    region. ``lines`` adds named edge sets ((k, 2) node pairs: constraint lines) and ``pinned``
    nodes that are fixed besides those on lines (constraint points). Raises
    :class:`InvalidTag` for a run along no boundary edge."""
    tagging = tagging or Tagging()
    edges = mesh.boundary_edges
    mid = mesh.points[edges].mean(axis=1)
    mids = shapely.points(mid)
    tree, ring_of = _ring_segments(region)
    nearest = tree.query_nearest(mids, all_matches=False)
    ring = np.empty(len(edges), dtype=np.int64)
    ring[nearest[0]] = ring_of[nearest[1]]
    names: dict[str, int] = {}
    ring_tag = np.array(
        [names.setdefault(n, len(names) + 1) for n in default_tag_names(region, tagging)],
        dtype=np.int64,
    )
    tag = ring_tag[ring]
    tol = _ON_SEGMENT * max(np.ptp(mesh.points, axis=0).max(), 1e-300)
    for i, run in enumerate(tagging.runs):
        on = shapely.dwithin(run.line(), mids, tol)
        if not on.any():
            raise InvalidTag(f"tag run {i} ({run.name!r}) follows no boundary edge", run=i)
        tag[on] = names.setdefault(run.name, len(names) + 1)
    region_id = triangle_regions(mesh, region)
    parts = region_names(region, tagging)
    inner, pairs = interface_edges(mesh.triangles, region_id)
    if len(inner):  # subdomains: each interface is tagged "<region a>|<region b>"
        edges = np.concatenate([edges, inner])
        tag = np.concatenate(
            [
                tag,
                [
                    names.setdefault(f"{parts[a - 1]}|{parts[b - 1]}", len(names) + 1)
                    for a, b in pairs
                ],
            ]
        ).astype(np.int64)
    for name, more in (lines or {}).items():
        pairs_ = np.asarray(more, dtype=np.int64).reshape(-1, 2)
        edges = np.concatenate([edges, pairs_])
        tag = np.concatenate([tag, np.full(len(pairs_), names.setdefault(name, len(names) + 1))])
    used = np.unique(tag)
    # Ids stay those of first naming, so defaults a run replaced everywhere leave a gap rather
    # than renumbering the runs.
    tags = {n: t for n, t in names.items() if t in used}
    fixed = np.zeros(mesh.n_points, dtype=bool)
    fixed[edges.ravel()] = True
    fixed[np.asarray(pinned, dtype=np.int64)] = True
    return MeshTags(
        lines=edges.astype(np.int64),
        line_tag=tag,
        tags=tags,
        region=region_id,
        regions={n: i + 1 for i, n in enumerate(parts)},
        fixed=fixed,
    )
