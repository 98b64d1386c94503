"""The floating-point genetic-algorithm smoother (registry name ``ga``).

For each interior node a small GA searches the node's best position: a chromosome is a candidate
``(x, y)``; the population is the current position plus uniform draws in the bounding box of the
node's star; candidates that would invert or flatten a star triangle have fitness 0; roulette-wheel
selection, one-point crossover, uniform mutation and elitism run for ``generations`` generations
(:mod:`engine.ga_kernels`).

Which nodes evolve
------------------
``selection="poor"`` (the default) evolves the nodes of poorly shaped triangles: those whose
star holds a triangle of shape quality below ``poor_quality`` (0.9 by default), and their
neighbours, which a poor node needs to make room. ``selection="all"`` (the paper's) evolves
every movable node. Either is further restricted to nodes whose fitness is below
``threshold`` when one is given, and after the first sweep to nodes whose star changed since
they last evolved (the neighbours of nodes that moved); "poor" is decided again each sweep at
the current positions, so a neighbour joins when a move leaves its star poor. Sweeps visit
the chosen nodes worst first (by the worst triangle of their star); each sweep's
:class:`~engine.result.SweepStats` says how many nodes it evolved and how many moved.

On a mesh from the mesher most triangles are already good: on plate_hole at h = 0.015 (38,484
triangles) "all" runs 29,051 node-GAs over three sweeps to lift the worst radius ratio from
0.864 to 0.912 (gmsh's optimiser: 0.676), "poor" 11 to reach 0.884 (benchmarks/smooth_bench.py).
On 148 random regions of the mesher's property tests (GA at 30 x 15), the worst shape quality
with "poor" was on average 0.007 and at most 0.037 below that with "all"; a test holds it to
:data:`POOR_LOSS`.

A sweep colours the chosen nodes greedily in that order into independent sets
(:mod:`engine.colouring`) and evolves each set at once. Sweeps stop when the largest fitness
change of a sweep is below ``tolerance``, when nothing is left to evolve, or after
``max_sweeps``.

What is guaranteed
------------------
Decided with the exact fitness that is reported (:func:`engine.fitness.node_fitness`), a node
moves only if

1. its own fitness strictly increases,
2. the worst shape quality of its star does not decrease, and
3. every triangle of its star keeps shape quality above :data:`engine.star.MIN_QUALITY`.

Hence the worst triangle of the mesh never gets worse, no triangle inverts or flattens, and each
move raises the fitness of the node that moves. A move also changes the fitness of the node's
neighbours, which may go down: requiring that they never do (so that *no* node's fitness could
drop) froze the smoother on jittered meshes (on the poor unit-square benchmark mesh the worst
radius ratio stayed at 0.03 with ``combined`` and 0.05 with ``worst``, instead of reaching 0.68 and
0.80), so it is not a rule. With the ``worst`` fitness the
rules imply that the smallest node fitness of the mesh never decreases. The output depends only
on the generator's state and the parameters, not on the number of threads.
"""

from __future__ import annotations

import time

import numba
import numpy as np
from numpy.typing import NDArray

from .colouring import independent_sets
from .errors import Cancelled
from .fitness import fitness_code
from .ga_kernels import accept_moves, draws_per_generation, ga_init, ga_step, single_width
from .mesh import Mesh
from .params import SmoothingParams
from .result import ProgressFn, SmoothOutcome, StopFn, SweepStats
from .rng import base_seed, stream_keys
from .star import Stars, all_fitness, build_stars, mark_neighbours, star_min_qualities

__all__ = ["POOR_LOSS", "ga_smooth"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Documented bound: "poor" selection's worst shape quality is at most this below "all"'s on
#: the property-test regions (measured: at most 0.037).
POOR_LOSS = 0.05
#: Nodes evolved per kernel call: bounds the GA's arrays (about 8 KB per node at P = 100).
_BLOCK = 4096
#: A kernel call should evaluate at least this many candidates between progress checks (some
#: 20-50 ms of work): each call is a parallel region whose start and end cost a scheduler
#: quantum or more when other processes share the cores.
_EVALS_PER_CALL = 2_000_000
#: Nodes handed to a thread at a time by the parallel kernels.
_NODES_PER_CHUNK = 16
#: A set uses one thread per this many nodes (some 7 ms of work each): waking a thread costs
#: more than a few nodes' GAs on a busy machine (8 nodes: 15 ms on two threads, 2.5 ms on one).
_NODES_PER_THREAD = 64
#: Tries of a shorter step toward the GA's best position when the full step is refused.
_HALVINGS = 2


def _worst_first(candidates: IntArray, points: FloatArray, stars: Stars) -> IntArray:
    worst = star_min_qualities(candidates, points, stars.ptr, stars.opp_a, stars.opp_b)
    return candidates[np.argsort(worst, kind="stable")]


class _Run:
    """State of one GA smoothing run."""

    def __init__(
        self,
        mesh: Mesh,
        params: SmoothingParams,
        rng: np.random.Generator,
        progress: ProgressFn,
        should_stop: StopFn,
    ) -> None:
        self.p = params
        self.kind = fitness_code(params.fitness)
        self.stars = s = build_stars(mesh.triangles, mesh.n_points)
        self.points = np.array(mesh.points, dtype=np.float64, order="C")
        self.movable = ~mesh.boundary_nodes
        self.base = base_seed(rng)
        self.progress, self.should_stop = progress, should_stop
        self.args = (s.ptr, s.opp_a, s.opp_b, self.kind, float(params.alpha), float(params.beta))
        self.fitness = all_fitness(self.points, *self.args)
        self.dirty = self.movable.copy()  # star changed since the node last evolved
        # Progress: each sweep takes the share of what is left that its node-GAs are of the
        # node-GAs still expected (see _expect); within a sweep it moves with those done.
        self.sweep_start, self.sweep_share, self.sweep_nodes, self.sweep_done = 0.0, 1.0, 1, 0
        self.reported, self.previous_sweep = 0.0, 0

    def _expect(self, sweep: int, count: int) -> None:
        """Set this sweep's share of the remaining progress: its ``count`` node-GAs against
        those expected of later sweeps, taken to shrink as the last two did (by half after a
        first sweep; plate_hole's "all" sweeps ran 4,701, 1,925 and 1,421 node-GAs) up to
        ``max_sweeps``. The run may stop earlier; the pipeline then reports the stage done."""
        ratio = min(count / self.previous_sweep, 0.9) if self.previous_sweep else 0.5
        later, size = 0.0, float(count)
        for _ in range(self.p.max_sweeps - sweep):
            size *= ratio
            later += size
        self.sweep_start = self.reported
        self.sweep_share = (1.0 - self.reported) * count / max(count + later, 1.0)
        self.sweep_nodes, self.previous_sweep = max(count, 1), count

    def _report(self, done: float) -> None:
        """Report progress after ``done`` node-GAs of the current sweep."""
        fraction = self.sweep_start + self.sweep_share * min(done / self.sweep_nodes, 1.0)
        self.reported = max(self.reported, fraction)
        self.progress("smooth", self.reported)

    def _candidates(self) -> IntArray:
        pick = self.movable & self.dirty
        if self.p.threshold is not None:
            pick &= self.fitness < self.p.threshold
        if self.p.selection == "poor":
            s = self.stars
            every = np.arange(len(self.movable), dtype=np.int64)
            worst = star_min_qualities(every, self.points, s.ptr, s.opp_a, s.opp_b)
            near = np.zeros_like(pick)
            mark_neighbours(every[worst < self.p.poor_quality], s.ptr, s.opp_a, s.opp_b, near)
            pick &= near
        return np.flatnonzero(pick).astype(np.int64)

    def _evolve(self, nodes: IntArray, sweep: int) -> BoolArray:
        """Run the GA of an independent set and apply the accepted moves; True where moved."""
        p = self.p
        k, size, gens = len(nodes), p.population, p.generations
        pop_x, pop_y, fit = np.empty((k, size)), np.empty((k, size)), np.empty((k, size))
        best, box, work = np.empty((k, 5)), np.empty((k, 5)), np.empty((k, 3, size))
        single = np.empty((k, 5, single_width(size)), dtype=np.float32)
        draws = np.empty((k, draws_per_generation(size)))
        picks = np.empty((k, 2, size), dtype=np.int64)
        keys = stream_keys(self.base, sweep, nodes)
        state = (pop_x, pop_y, fit, best, box)
        chunk = max(1, -(-_EVALS_PER_CALL // (k * size)))
        done = 0
        # Small chunks of nodes per thread: a core busy with other work then slows one chunk,
        # not a fixed half of the set (results do not depend on it).
        previous = numba.set_parallel_chunksize(_NODES_PER_CHUNK)
        threads = numba.get_num_threads()
        numba.set_num_threads(max(1, min(threads, -(-k // _NODES_PER_THREAD))))
        try:
            ga_init(nodes, keys, self.points, *self.args, *state, single)
            while done < gens:
                if self.should_stop():
                    raise Cancelled("smoothing stopped between GA generations")
                count = min(chunk, gens - done)
                rates = (p.crossover_rate, p.mutation_rate, p.patience or 0)
                ga_step(nodes, keys, done + 1, count, self.points, *self.args, *rates, *state,
                        work, single, draws, picks)  # fmt: skip
                done += count
                self._report(self.sweep_done + k * done / gens)
        finally:
            numba.set_parallel_chunksize(previous)
            numba.set_num_threads(threads)
        moved = np.zeros(k, dtype=np.bool_)
        accept_moves(nodes, best, self.points, self.fitness, *self.args, _HALVINGS, moved)
        self.sweep_done += k
        return moved

    def sweep(self, sweep: int) -> SweepStats:
        t0 = time.perf_counter()
        s = self.stars
        before = self.fitness.copy()
        nodes = _worst_first(self._candidates(), self.points, s)
        self.dirty[nodes] = False
        self._expect(sweep, len(nodes))
        self.sweep_done, moved_count = 0, 0
        for group in independent_sets(nodes, s.ptr, s.opp_a, s.opp_b):
            for first in range(0, len(group), _BLOCK):
                block = np.ascontiguousarray(group[first : first + _BLOCK])
                moved = self._evolve(block, sweep)
                mark_neighbours(block[moved], s.ptr, s.opp_a, s.opp_b, self.dirty)
                moved_count += int(moved.sum())
        self.dirty &= self.movable
        inner = self.fitness[self.movable]
        return SweepStats(
            sweep=sweep,
            mean_fitness=float(inner.mean()) if inner.size else 0.0,
            min_fitness=float(inner.min()) if inner.size else 0.0,
            max_change=float(np.abs(self.fitness - before).max(initial=0.0)),
            nodes_evolved=len(nodes),
            nodes_moved=moved_count,
            seconds=time.perf_counter() - t0,
        )


def ga_smooth(
    mesh: Mesh,
    params: SmoothingParams,
    rng: np.random.Generator,
    progress: ProgressFn,
    should_stop: StopFn,
) -> SmoothOutcome:
    """Smooth the interior nodes of ``mesh`` with the GA; see the module docstring for guarantees.

    >>> pts = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [0.3, 1.6]])
    >>> tri = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    >>> out = ga_smooth(Mesh(pts, tri), SmoothingParams(), np.random.default_rng(0),
    ...                 lambda stage, f: None, lambda: False)
    >>> bool(np.allclose(out.points[4], [1, 1], atol=0.02)), out.history[0].nodes_moved
    (True, 1)
    """
    run = _Run(mesh, params, rng, progress, should_stop)
    history: list[SweepStats] = []
    for sweep in range(1, params.max_sweeps + 1):
        if not run.dirty.any():
            break
        stats = run.sweep(sweep)
        history.append(stats)
        if stats.max_change < params.tolerance:
            break
    return SmoothOutcome(points=run.points, history=tuple(history), fitness=run.fitness)
