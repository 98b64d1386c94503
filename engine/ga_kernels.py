"""Numba kernels of the genetic algorithm: one independent set of nodes evolves at once.

Nodes of one set share no triangle, so each node's GA reads only fixed neighbour positions and
writes only its own rows: the ``prange`` loops below are race-free, and since every random draw
comes from the node's own counter-based stream (:mod:`engine.rng`), a node's result is the same
whichever thread runs it.

Inside the GA loop candidates are evaluated in single precision (eight to a vector register
with AVX2) with a polynomial arctangent: the fitness is within about 1e-6 of the exact one and
guides selection only. Whether a node moves is decided by :func:`accept_moves` with the exact
double-precision fitness of :mod:`engine.star`, the value that is reported.
"""

from __future__ import annotations

import math
import os

import numba
import numpy as np
from numpy.typing import NDArray

from .rng import uniform_pair
from .star import MIN_QUALITY, NEEDS_ANGLE, combine, star_fitness, star_min_quality

__all__ = [
    "STALL_GAIN",
    "accept_moves",
    "crossover",
    "draws_per_generation",
    "evaluate",
    "ga_init",
    "ga_step",
    "mutate",
    "roulette",
    "single_width",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
UIntArray = NDArray[np.uint64]
Float32Array = NDArray[np.float32]

# OpenMP threads that wait (for the next parallel region, or at a region's end for a slower
# thread) spin for some 300,000 iterations by default. Each independent set is a few parallel
# regions with serial work between them (accepting moves, progress), so on two threads the
# spinning cost 20% more CPU per node-GA (12,800 -> 10,400 per CPU-second on unit_square.poor)
# and took a core from the thread with work when the machine is shared. Passive waiting
# sleeps at once; waking costs microseconds against regions of tens of milliseconds. OpenMP
# reads this when numba first loads it, at the first parallel kernel call, after this import;
# a value the user set is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

_F32 = np.float32
#: A node's GA has converged when its best fitness rose by no more than this (a fitness unit is
#: the whole [0, 1] range) in ``patience`` generations.
STALL_GAIN = 1e-4
#: Single-precision numbers per vector register the padding is for (AVX2; AVX-512 holds 16).
_LANES = 8
# Single-precision constants: a float64 constant would promote the whole loop to double.
_TWO_SQRT3 = _F32(2.0 * math.sqrt(3.0))
_THIRD_PI = _F32(math.pi / 3.0)
_HALF_PI = _F32(0.5 * math.pi)
_PI = _F32(math.pi)
_ZERO, _ONE, _TINY = _F32(0.0), _F32(1.0), _F32(1e-30)
_INF = _F32(math.inf)
_ANGLE_SCALE = (180.0 / math.pi) ** 2 / 21600.0  # squared radians -> the fitness's degree units
# atan(r) ~ r * P(r^2) on [0, 1]: least-maximum-error fit, |error| < 3.8e-8 rad in exact
# arithmetic (about 1e-7 in single precision).
_A0, _A1, _A2, _A3 = _F32(0.99999934), _F32(-0.33329861), _F32(0.19946566), _F32(-0.13908629)
_A4, _A5, _A6, _A7 = _F32(0.09642195), _F32(-0.05591229), _F32(0.02186293), _F32(-0.00405456)


@numba.njit(cache=True, inline="always")
def _atan_unit(r: np.float32) -> np.float32:
    """``atan(r)`` for ``0 <= r <= 1``, in single precision."""
    r2 = r * r
    p = ((((((_A7 * r2 + _A6) * r2 + _A5) * r2 + _A4) * r2 + _A3) * r2 + _A2) * r2 + _A1) * r2
    return r * (p + _A0)


# error_model="numpy": a division must not raise (its check would stop the loops vectorising);
# contract/arcp: fused multiply-adds and reciprocals, only in this guiding approximation.
@numba.njit(cache=True, error_model="numpy", fastmath={"contract", "arcp"})
def evaluate(
    xs: FloatArray,
    ys: FloatArray,
    out: FloatArray,
    work: Float32Array,
    box: FloatArray,
    j0: int,
    j1: int,
    points: FloatArray,
    opp_a: IntArray,
    opp_b: IntArray,
    kind: int,
    alpha: float,
    beta: float,
) -> None:
    """GA fitness of candidates ``(xs, ys)`` for the star entries ``j0:j1``; 0 if inadmissible.

    ``work`` is (5, :func:`single_width` (P)) single-precision scratch; ``box`` is the node's
    search box (x0, width, y0, height, scale). Coordinates are taken relative to the box's
    corner and multiplied by ``scale`` (a power of two near 1 / box size) in double precision,
    so every offset below is O(1): single precision then loses nothing that matters to a guide
    (fitness within about 1e-6 of the exact one), and the one division per triangle (shared by
    the quality and the two arctangent ratios) can neither overflow nor underflow. Single
    precision doubles the candidates one vector instruction handles; the rows are padded to
    whole vectors (the padding repeats candidate 0), so no candidate falls to a scalar
    remainder loop.
    """
    n, m = len(xs), work.shape[1]
    s_err, s_q, worst, X, Y = work[0], work[1], work[2], work[3], work[4]
    ox, oy, scale = box[0], box[2], box[4]
    for c in range(m):
        s_err[c] = _ZERO
        s_q[c] = _ZERO
        worst[c] = _INF
        i = c if c < n else 0  # padding repeats candidate 0
        X[c] = _F32((xs[i] - ox) * scale)
        Y[c] = _F32((ys[i] - oy) * scale)
    need_angle = NEEDS_ANGLE[kind]
    for j in range(j0, j1):
        ax, ay = _F32((points[opp_a[j], 0] - ox) * scale), _F32((points[opp_a[j], 1] - oy) * scale)
        bx, by = _F32((points[opp_b[j], 0] - ox) * scale), _F32((points[opp_b[j], 1] - oy) * scale)
        ex, ey = bx - ax, by - ay
        s0 = ex * ex + ey * ey
        if need_angle:
            for c in range(m):
                dax, day = ax - X[c], ay - Y[c]
                dbx, dby = bx - X[c], by - Y[c]
                cross = dax * dby - day * dbx
                total = max(s0 + (dbx * dbx + dby * dby) + (dax * dax + day * day), _TINY)
                # The angles at p and at a from atan2(|cross|, dot); the one at b is the rest.
                h = abs(cross)
                dp = dax * dbx + day * dby
                da = -(dax * ex + day * ey)
                big_p, small_p = max(max(abs(dp), h), _TINY), min(abs(dp), h)
                big_a, small_a = max(max(abs(da), h), _TINY), min(abs(da), h)
                inv = _ONE / (big_p * big_a * total)
                q = _TWO_SQRT3 * cross * (big_p * big_a * inv)
                tp = _atan_unit(small_p * (big_a * total * inv))
                ta = _atan_unit(small_a * (big_p * total * inv))
                tp = _HALF_PI - tp if h > abs(dp) else tp
                tp = _PI - tp if dp < _ZERO else tp
                ta = _HALF_PI - ta if h > abs(da) else ta
                ta = _PI - ta if da < _ZERO else ta
                tb = _PI - tp - ta
                ep, ea, eb = tp - _THIRD_PI, ta - _THIRD_PI, tb - _THIRD_PI
                s_err[c] += ep * ep + ea * ea + eb * eb
                s_q[c] += q
                # A NaN quality (coincident points) must make the candidate inadmissible.
                worst[c] = worst[c] if q >= worst[c] else q
        else:
            for c in range(m):
                dax, day = ax - X[c], ay - Y[c]
                dbx, dby = bx - X[c], by - Y[c]
                cross = dax * dby - day * dbx
                total = max(s0 + (dbx * dbx + dby * dby) + (dax * dax + day * day), _TINY)
                q = _TWO_SQRT3 * cross / total
                s_q[c] += q
                worst[c] = worst[c] if q >= worst[c] else q
    k = max(j1 - j0, 1)
    for c in range(n):
        angle = 1.0 - float(s_err[c]) * _ANGLE_SCALE / k
        low = float(worst[c])
        f = combine(kind, angle, float(s_q[c]) / k, low, alpha, beta)
        out[c] = f if low > MIN_QUALITY and f > 0.0 else 0.0


def single_width(population: int) -> int:
    """Length of :func:`evaluate`'s scratch rows: the population rounded up to whole vectors.

    >>> single_width(100), single_width(16)
    (104, 16)
    """
    return -(-population // _LANES) * _LANES


def draws_per_generation(population: int) -> int:
    """Random numbers one generation consumes per node (a fixed count, so streams stay aligned):
    one per selection slot, one per crossing pair, two per gene; rounded up to whole pairs.

    >>> draws_per_generation(100), draws_per_generation(13)
    (550, 72)
    """
    n = population + population // 2 + 4 * population
    return n + n % 2


@numba.njit(cache=True, parallel=True)
def ga_init(
    nodes: IntArray,
    keys: UIntArray,
    points: FloatArray,
    ptr: IntArray,
    opp_a: IntArray,
    opp_b: IntArray,
    kind: int,
    alpha: float,
    beta: float,
    pop_x: FloatArray,
    pop_y: FloatArray,
    fit: FloatArray,
    best: FloatArray,
    box: FloatArray,
    single: Float32Array,
) -> None:
    """First generation of every node of the set, evaluated; sets each node's search box.

    Slot 0 holds the node's current position (so the GA can only find better), slots 1..P-1
    uniform draws in the bounding box of the node's neighbours, which contains every admissible
    position. ``box`` gets (x0, width, y0, height, scale) per node; ``single`` is
    :func:`evaluate`'s scratch.
    """
    size = pop_x.shape[1]
    for s in numba.prange(len(nodes)):
        node, key = nodes[s], keys[s]
        j0, j1 = ptr[node], ptr[node + 1]
        x0, x1 = math.inf, -math.inf
        y0, y1 = math.inf, -math.inf
        for j in range(j0, j1):
            for v in (opp_a[j], opp_b[j]):
                x0, x1 = min(x0, points[v, 0]), max(x1, points[v, 0])
                y0, y1 = min(y0, points[v, 1]), max(y1, points[v, 1])
        box[s, 0], box[s, 1], box[s, 2], box[s, 3] = x0, x1 - x0, y0, y1 - y0
        size_exp = math.frexp(max(x1 - x0, y1 - y0, 1e-300))[1]
        box[s, 4] = math.ldexp(1.0, -size_exp)  # a power of two: scaling by it is exact
        xs, ys = pop_x[s], pop_y[s]
        xs[0], ys[0] = points[node, 0], points[node, 1]
        for c in range(1, size):
            ux, uy = uniform_pair(key, np.uint64(c))
            xs[c] = x0 + (x1 - x0) * ux
            ys[c] = y0 + (y1 - y0) * uy
        evaluate(xs, ys, fit[s], single[s], box[s], j0, j1, points, opp_a, opp_b, kind, alpha, beta)
        b = np.argmax(fit[s])
        best[s, 0], best[s, 1], best[s, 2] = xs[b], ys[b], fit[s, b]
        best[s, 3], best[s, 4] = fit[s, b], 0.0


@numba.njit(cache=True, inline="always")
def roulette(
    f: FloatArray, cum: FloatArray, guide: IntArray, u: FloatArray, picks: IntArray
) -> None:
    """Roulette-wheel picks: ``picks[c]`` is the smallest i with ``cum[i] > u[c] * total``.

    This inverts the cumulative fitness through a guide table (Chen and Asau 1974): bucket k of
    the wheel remembers the first candidate that can end in it, so a draw costs O(1) on average;
    the result is exactly that of a binary search, which is several times slower here (its
    branches are unpredictable). All-zero fitness (every candidate inadmissible) picks uniformly.
    """
    size = len(f)
    last = size - 1
    total = 0.0
    for c in range(size):
        total += f[c]
        cum[c] = total
        guide[c] = 0
    if not total > 0.0:
        for c in range(size):
            picks[c] = min(int(u[c] * size), last)
        return
    scale = size / total
    for c in range(size):
        guide[min(int(cum[c] * scale), last)] += 1
    first = 0
    for k in range(size):
        count = guide[k]
        guide[k] = min(first, last)
        first += count
    for c in range(size):
        r = u[c] * total
        i = guide[min(int(u[c] * size), last)]
        while i > 0 and cum[i - 1] > r:  # only on rounding at a bucket edge
            i -= 1
        # Usually zero to two steps forward: take two without branching, loop for the rest.
        i = min(i + (cum[i] <= r), last)
        i = min(i + (cum[i] <= r), last)
        while i < last and cum[i] <= r:
            i += 1
        picks[c] = i


@numba.njit(cache=True, inline="always")
def crossover(genes: FloatArray, u: FloatArray, rate: float) -> None:
    """One-point crossover of pairs (0, 1), (2, 3), ...: with two genes per chromosome the only
    cut is between x and y, so a crossing pair swaps its y genes; pair p crosses if ``u[p] <
    rate``. ``genes`` holds the y genes."""
    for p in range(len(genes) // 2):
        a, b = genes[2 * p], genes[2 * p + 1]
        swap = u[p] < rate
        genes[2 * p] = b if swap else a
        genes[2 * p + 1] = a if swap else b


@numba.njit(cache=True, inline="always")
def mutate(
    nx: FloatArray,
    ny: FloatArray,
    xs: FloatArray,
    ys: FloatArray,
    decide: FloatArray,
    values: FloatArray,
    box: FloatArray,
    rate: float,
) -> None:
    """Uniform mutation from ``(nx, ny)`` into ``(xs, ys)``: gene g of candidate c (x: g = 2c,
    y: g = 2c + 1) is replaced when ``decide[g] < rate`` by a uniform draw in the search box
    ``box = (x0, width, y0, height)``, ``values[g]`` giving its position."""
    x0, wx, y0, wy = box[0], box[1], box[2], box[3]
    for c in range(len(nx)):
        mx = x0 + wx * values[2 * c]
        my = y0 + wy * values[2 * c + 1]
        xs[c] = mx if decide[2 * c] < rate else nx[c]
        ys[c] = my if decide[2 * c + 1] < rate else ny[c]


@numba.njit(cache=True, parallel=True)
def ga_step(
    nodes: IntArray,
    keys: UIntArray,
    first: int,
    count: int,
    points: FloatArray,
    ptr: IntArray,
    opp_a: IntArray,
    opp_b: IntArray,
    kind: int,
    alpha: float,
    beta: float,
    crossover_rate: float,
    mutation_rate: float,
    patience: int,
    pop_x: FloatArray,
    pop_y: FloatArray,
    fit: FloatArray,
    best: FloatArray,
    box: FloatArray,
    work: FloatArray,
    single: Float32Array,
    draws: FloatArray,
    picks: IntArray,
) -> None:
    """Generations ``first .. first+count-1`` (1-based) of every node of the set.

    Each generation: roulette-wheel selection (one draw per slot against the cumulative
    fitness), one-point crossover of pairs (with two genes: swap the y genes), uniform mutation
    of each gene, then the best candidate so far replaces slot 0 (elitism). A node whose best
    fitness has not risen by more than :data:`STALL_GAIN` in ``patience`` generations has
    converged and skips the rest (``patience`` 0: never). ``best`` is (S, 5): position and
    fitness of the best candidate, the best fitness at the last gain and the generations since.
    ``work`` (S, 3, P),
    ``single`` (S, 5, P, single precision, for :func:`evaluate`), ``draws`` (S, D) and ``picks``
    (S, 2, P) are scratch; D is :func:`draws_per_generation`.
    """
    size = pop_x.shape[1]
    half = size // 2
    per_gen = draws.shape[1]
    cross0, mut0 = size, size + half
    val0 = mut0 + 2 * size
    for s in numba.prange(len(nodes)):
        node, key = nodes[s], keys[s]
        j0, j1 = ptr[node], ptr[node + 1]
        xs, ys, f, u = pop_x[s], pop_y[s], fit[s], draws[s]
        cum, nx, ny = work[s, 0], work[s, 1], work[s, 2]
        pick, guide = picks[s, 0], picks[s, 1]
        for g in range(first, first + count):
            if patience > 0 and best[s, 4] >= patience:
                break  # converged: no gain above STALL_GAIN for `patience` generations
            # Pairs 0..P-1 of the stream seeded the first generation.
            base = np.uint64(size + (g - 1) * (per_gen // 2))
            for i in range(per_gen // 2):
                u[2 * i], u[2 * i + 1] = uniform_pair(key, base + np.uint64(i))
            roulette(f, cum, guide, u, pick)
            for c in range(size):
                nx[c], ny[c] = xs[pick[c]], ys[pick[c]]
            crossover(ny, u[cross0:mut0], crossover_rate)
            mutate(nx, ny, xs, ys, u[mut0:val0], u[val0:], box[s], mutation_rate)
            xs[0], ys[0] = best[s, 0], best[s, 1]
            evaluate(xs, ys, f, single[s], box[s], j0, j1, points, opp_a, opp_b, kind, alpha, beta)
            b = np.argmax(f)
            if f[b] > best[s, 2]:
                best[s, 0], best[s, 1], best[s, 2] = xs[b], ys[b], f[b]
            if best[s, 2] > best[s, 3] + STALL_GAIN:
                best[s, 3], best[s, 4] = best[s, 2], 0.0
            else:
                best[s, 4] += 1.0


@numba.njit(cache=True)
def accept_moves(
    nodes: IntArray,
    best: FloatArray,
    points: FloatArray,
    fitness: FloatArray,
    ptr: IntArray,
    opp_a: IntArray,
    opp_b: IntArray,
    kind: int,
    alpha: float,
    beta: float,
    halvings: int,
    moved: NDArray[np.bool_],
) -> None:
    """Move each node of the set, in order, to its GA result when that is an improvement.

    A move of node n from p toward the GA's best p' is tried at p', then at p + (p' - p) / 2,
    / 4, ... (``halvings`` times; the star's kernel is convex, so these points stay admissible).
    It is kept at the first point where, computed exactly:

    - every triangle of n's star has shape quality above :data:`~engine.star.MIN_QUALITY`;
    - the worst shape quality of n's star is not lower than before;
    - n's fitness is strictly higher than before.

    ``points`` and ``fitness`` are updated in place; ``fitness`` must hold the exact current
    fitness of every node, and still does afterwards (n's and its neighbours' are recomputed).
    """
    for s in range(len(nodes)):
        n = nodes[s]
        px, py = points[n, 0], points[n, 1]
        dx, dy = best[s, 0] - px, best[s, 1] - py
        old_worst = star_min_quality(px, py, n, points, ptr, opp_a, opp_b)
        step = 1.0
        for _ in range(halvings + 1):
            x, y = px + step * dx, py + step * dy
            step *= 0.5
            worst = star_min_quality(x, y, n, points, ptr, opp_a, opp_b)
            if worst <= MIN_QUALITY or worst < old_worst:
                continue
            f = star_fitness(x, y, n, points, ptr, opp_a, opp_b, kind, alpha, beta)
            if not f > fitness[n]:
                continue
            points[n, 0], points[n, 1] = x, y
            fitness[n] = f
            # An interior node's neighbours are its star's opp_a entries, once each.
            for j in range(ptr[n], ptr[n + 1]):
                m = opp_a[j]
                fitness[m] = star_fitness(
                    points[m, 0], points[m, 1], m, points, ptr, opp_a, opp_b, kind, alpha, beta
                )
            moved[s] = True
            break
