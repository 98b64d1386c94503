"""Planar predicates and constructions on coordinates (numba, inlined into the front kernels)."""

from __future__ import annotations

import math

import numba as nb

from .constants import TWO_PI


@nb.njit(cache=True, inline="always")
def orient(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    """Twice the signed area of (a, b, c): positive when counter-clockwise."""
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@nb.njit(cache=True, inline="always")
def ccw(ux: float, uy: float, vx: float, vy: float) -> float:
    """Angle from vector u counter-clockwise to vector v, in [0, 2 pi)."""
    a = math.atan2(ux * vy - uy * vx, ux * vx + uy * vy)
    if a < 0.0:
        a += TWO_PI
    return a


@nb.njit(cache=True, inline="always")
def circumcircle(
    ax: float, ay: float, bx: float, by: float, cx: float, cy: float
) -> tuple[float, float, float]:
    """Centre and radius of the circle through a, b, c (radius inf when they are collinear)."""
    d = 2.0 * orient(ax, ay, bx, by, cx, cy)
    if d == 0.0:
        return 0.5 * (ax + bx), 0.5 * (ay + by), math.inf
    b2x, b2y, c2x, c2y = bx - ax, by - ay, cx - ax, cy - ay
    bb, cc = b2x * b2x + b2y * b2y, c2x * c2x + c2y * c2y
    ox = (c2y * bb - b2y * cc) / d
    oy = (b2x * cc - c2x * bb) / d
    return ax + ox, ay + oy, math.hypot(ox, oy)


@nb.njit(cache=True, inline="always")
def seg_dist2(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    """Squared distance from p to the segment a-b."""
    dx, dy = bx - ax, by - ay
    ll = dx * dx + dy * dy
    t = 0.0
    if ll > 0.0:
        t = min(max(((px - ax) * dx + (py - ay) * dy) / ll, 0.0), 1.0)
    qx, qy = ax + t * dx - px, ay + t * dy - py
    return qx * qx + qy * qy


@nb.njit(cache=True, inline="always")
def segments_meet(
    p1x: float, p1y: float, p2x: float, p2y: float,
    q1x: float, q1y: float, q2x: float, q2y: float, tol: float,
) -> bool:  # fmt: skip
    """Whether two segments cross or come within ``tol`` of touching (conservative)."""
    lq = math.hypot(q2x - q1x, q2y - q1y)
    d1 = orient(q1x, q1y, q2x, q2y, p1x, p1y)
    d2 = orient(q1x, q1y, q2x, q2y, p2x, p2y)
    if (d1 > tol * lq and d2 > tol * lq) or (d1 < -tol * lq and d2 < -tol * lq):
        return False
    lp = math.hypot(p2x - p1x, p2y - p1y)  # only now: most pairs are apart by the first test
    d3 = orient(p1x, p1y, p2x, p2y, q1x, q1y)
    d4 = orient(p1x, p1y, p2x, p2y, q2x, q2y)
    if (d3 > tol * lp and d4 > tol * lp) or (d3 < -tol * lp and d4 < -tol * lp):
        return False
    # Straddling (or nearly collinear): they meet unless their boxes are apart.
    if min(p1x, p2x) > max(q1x, q2x) + tol or min(q1x, q2x) > max(p1x, p2x) + tol:
        return False
    return not (min(p1y, p2y) > max(q1y, q2y) + tol or min(q1y, q2y) > max(p1y, p2y) + tol)
