"""Boundary discretisation: split every ring segment to follow the size field.

Every input vertex is kept. A segment of length ``L`` gets ``n = round(integral of ds / h)``
pieces (at least one), placed at equal steps of that integral, so a uniform field splits it evenly
and a graded field grades it.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import NDArray

from .boundary import Region
from .errors import Cancelled, LimitExceeded
from .result import ProgressFn, StopFn
from .sizing import SizeField, SizeTuple
from .sizing import size_field_at as _size

__all__ = ["Discretized", "discretize"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_MAX_STEPS = 40_000_000
#: Corners below this interior angle (degrees) get their first boundary nodes opened up.
SHARP_CORNER_DEG = 60.0
#: Kept below ``2 cos(theta)`` for the ratio of a corner's second to first node distance.
LADDER_MARGIN = 0.2
#: Segments between two polls of ``should_stop``.
_POLL = 1024


@dataclass(frozen=True)
class Discretized:
    """Boundary points and edges of a region, ready for the mesher.

    Edges are directed with the region on their left; ``ring_of_edge`` names the ring (in
    ``Region.rings`` order) each edge belongs to.
    """

    points: FloatArray  #: (n, 2)
    edges: IntArray  #: (n, 2) directed boundary edges
    ring_of_edge: IntArray  #: (n,)
    ring_start: IntArray  #: (rings + 1,) offsets of each ring's points
    sizes: FloatArray  #: (n,) size field at each point


@nb.njit(cache=True)
def _march(
    ax: float, ay: float, bx: float, by: float, sf: SizeTuple, max_steps: int
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover - compiled
    """Parameters along a -> b in steps of a quarter of the local size, with the running
    integral of ds / h (trapezoid rule; accurate because h changes by at most 5% a step).
    Stops after ``max_steps`` steps; the arrays grow as needed."""
    length = math.hypot(bx - ax, by - ay)
    ts = np.empty(64)
    cum = np.empty(64)
    ts[0], cum[0] = 0.0, 0.0
    h_prev = _size(sf, ax, ay)
    n = 1
    t = 0.0
    while t < 1.0 and n <= max_steps:
        if n == ts.shape[0]:
            ts = np.concatenate((ts, np.empty(n)))
            cum = np.concatenate((cum, np.empty(n)))
        t = min(t + 0.25 * h_prev / length, 1.0)
        h = _size(sf, ax + t * (bx - ax), ay + t * (by - ay))
        ts[n] = t
        cum[n] = cum[n - 1] + 0.5 * (1.0 / h + 1.0 / h_prev) * (t - ts[n - 1]) * length
        h_prev = h
        n += 1
    return ts[:n], cum[:n]


def _split(a: FloatArray, b: FloatArray, field: SizeField) -> FloatArray:
    """Interior split points of segment ``a -> b`` (excluding both ends)."""
    t, cum = _march(a[0], a[1], b[0], b[1], field.as_tuple(), _MAX_STEPS)
    if t[-1] < 1.0:
        raise LimitExceeded(
            f"the boundary segment from ({a[0]:.6g}, {a[1]:.6g}) needs more than "
            f"{_MAX_STEPS // 4} points at this size",
            limit=_MAX_STEPS // 4,
            estimate=_MAX_STEPS // 4 + 1,
        )
    n = max(round(float(cum[-1])), 1)
    if n == 1:
        return np.empty((0, 2))
    ts = np.interp(cum[-1] * np.arange(1, n) / n, cum, t)
    return a + ts[:, None] * (b - a)


def _corner_ratio(ring: FloatArray) -> FloatArray:
    """For each vertex, the largest ratio between the distances of the second and the first
    node from it on each side for which a ladder of triangles across its wedge keeps the
    corner's angle (``2 cos(theta)``, less a margin); infinite where the corner is not sharp."""
    d_in = ring - np.roll(ring, 1, axis=0)
    d_out = np.roll(ring, -1, axis=0) - ring
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    interior = np.pi - np.arctan2(cross, (d_in * d_out).sum(axis=1))
    sharp = interior < np.radians(SHARP_CORNER_DEG)
    return np.where(sharp, 2.0 * np.cos(interior) - LADDER_MARGIN, np.inf)


def _open_corners(
    pts: FloatArray, a: FloatArray, b: FloatArray, ratio_a: float, ratio_b: float
) -> FloatArray:
    """Drop the split point nearest a sharp corner when the next one is too far beyond it.

    Nodes placed at equal steps of ``integral ds / h`` from a corner sit at distances ``s1``
    and about ``(2 + slope) s1``; the triangle joining the first node on one side to the first
    two on the other then has an angle of ``atan(sin(theta) / (s2 / s1 - cos(theta)))``, below
    the corner's ``theta`` (15 degrees at a 20-degree corner). Without the first node the
    ratio is about 1.65 and that angle is above ``min(theta, 30)`` degrees.
    """
    for end, ratio in ((a, ratio_a), (b, ratio_b)):
        if len(pts) < 2 or not np.isfinite(ratio):
            continue
        near, far = (0, 1) if end is a else (-1, -2)
        s1 = float(np.hypot(*(pts[near] - end)))
        s2 = float(np.hypot(*(pts[far] - end)))
        if s2 > ratio * s1:
            pts = np.delete(pts, near if near == 0 else len(pts) - 1, axis=0)
    return pts


def discretize(
    region: Region,
    field: SizeField,
    progress: ProgressFn | None = None,
    should_stop: StopFn | None = None,
    held: Collection[tuple[float, float, float, float]] = (),
) -> Discretized:
    """Points and directed edges of the boundary of ``region`` split to ``field``; the
    segments in ``held`` (by their ends' coordinates ``(ax, ay, bx, by)``, either way: a
    subdomain's pieces of shared edges, split once for both sides) are kept whole.

    ``should_stop()`` is polled every ``_POLL`` segments (:class:`Cancelled` when true).

    >>> from engine.boundary import make_region
    >>> from engine.params import SizingParams
    >>> from engine.sizing import build_size_field
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> d = discretize(square, build_size_field(square, SizingParams(size=0.25)))
    >>> len(d.points), d.edges[:2].tolist()
    (16, [[0, 1], [1, 2]])
    """
    points: list[FloatArray] = []
    edges: list[IntArray] = []
    ring_id: list[IntArray] = []
    starts = [0]
    offset = 0
    total = max(region.n_vertices, 1)
    done = 0
    held = frozenset(held)
    for r, ring in enumerate(region.rings):
        pieces: list[FloatArray] = []
        n = len(ring)
        ratio = _corner_ratio(ring)
        for i in range(len(ring)):
            if done % _POLL == 0:
                if progress is not None:
                    progress("discretize", done / total)
                if should_stop is not None and should_stop():
                    raise Cancelled("stopped while discretising the boundary")
            done += 1
            a, b = ring[i], ring[(i + 1) % len(ring)]
            pieces.append(a[None, :])
            if held and (*a.tolist(), *b.tolist()) in held:
                continue
            pieces.append(_open_corners(_split(a, b, field), a, b, ratio[i], ratio[(i + 1) % n]))
        pts = np.concatenate(pieces)
        idx = offset + np.arange(len(pts))
        points.append(pts)
        edges.append(np.stack([idx, np.roll(idx, -1)], axis=1))
        ring_id.append(np.full(len(pts), r))
        offset += len(pts)
        starts.append(offset)
    all_points = np.concatenate(points)
    return Discretized(
        points=all_points,
        edges=np.concatenate(edges).astype(np.int64),
        ring_of_edge=np.concatenate(ring_id).astype(np.int64),
        ring_start=np.asarray(starts, dtype=np.int64),
        sizes=field(all_points),
    )
