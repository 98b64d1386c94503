"""The pipeline: boundary -> advancing front -> diagonal swapping -> smoothing -> quality."""

from __future__ import annotations

import time
from collections.abc import Callable, Collection
from dataclasses import asdict, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .boundary import Region
from .collapse import collapse_edges
from .discretize import discretize
from .errors import Cancelled, LimitExceeded
from .estimate import estimate_triangles, refuse_by_area
from .fitness import node_fitness
from .front import advance_front
from .mesh import Mesh, keeps_boundary
from .params import PipelineParams, SizingParams, SmoothingParams
from .quality import shape_quality, summarize, triangle_quality
from .relax import relax, relax_mean
from .resample import resample_region
from .result import ProgressFn, Result, Snapshot, StopFn
from .sizing import build_size_field
from .slide import SLIDE_ROUNDS, slide_round
from .smoothing import SMOOTHERS, smooth_points
from .spanning import split_spanning
from .swap import regularise_valence, swap_diagonals

__all__ = [
    "STAGE_WEIGHTS",
    "STAGE_WORDS",
    "SUBSTAGES",
    "assess_mesh",
    "improve_mesh",
    "job_progress",
    "mesh_region",
    "mesh_then_smooth",
    "smooth_mesh",
]


#: What each stage does, in words, for progress messages.
STAGE_WORDS: dict[str, str] = {
    "boundary": "dividing the boundary",
    "mesh": "meshing (advancing front)",
    "swap": "swapping diagonals",
    "smooth": "smoothing",
}
#: The mesher's own stages (:func:`mesh_region`) as parts of the job's stages: (job stage, the
#: part of it where the sub-stage starts, where it ends); shares from the mesher's timings.
SUBSTAGES: dict[str, tuple[str, float, float]] = {
    "sizing": ("boundary", 0.0, 0.4),
    "estimate": ("boundary", 0.4, 0.7),
    "discretize": ("boundary", 0.7, 1.0),
    "front": ("mesh", 0.0, 0.6),
    "collapse": ("mesh", 0.75, 0.8),
    "relax": ("mesh", 0.6, 1.0),
}
#: Share of a job's time in each stage, in pipeline order, by smoothing selection: the means of
#: ``timings`` over the public cases and plate_hole at h = 0.015 (benchmarks/smooth_bench.py;
#: the assessments of the initial and swapped meshes count with "swap", the final one with
#: "smooth").
STAGE_WEIGHTS: dict[str, dict[str, float]] = {
    "poor": {"boundary": 0.07, "mesh": 0.46, "swap": 0.13, "smooth": 0.34},
    "all": {"boundary": 0.02, "mesh": 0.11, "swap": 0.03, "smooth": 0.84},
}


def job_progress(
    report: Callable[[int, str], None], smoothing: SmoothingParams | None = None
) -> ProgressFn:
    """A ``progress(stage, fraction)`` for the pipeline that calls ``report(percent, words)``
    for the whole job: each stage spans a share of 0-99 % in proportion to its measured cost
    (:data:`STAGE_WEIGHTS`), the message names the stage (:data:`STAGE_WORDS`), and the
    percentage never goes backwards (the smoother may run twice, see :func:`mesh_then_smooth`).

    >>> seen = []
    >>> progress = job_progress(lambda percent, words: seen.append((percent, words)))
    >>> progress("mesh", 1.0); progress("smooth", 0.5); progress("swap", 1.0)
    >>> seen
    [(52, 'meshing (advancing front)'), (82, 'smoothing'), (82, 'swapping diagonals')]
    """
    smoothing = smoothing or SmoothingParams()
    weights = STAGE_WEIGHTS[smoothing.selection if smoothing.method == "ga" else "poor"]
    total = sum(weights.values())
    start, at = {}, 0.0
    for stage, weight in weights.items():
        start[stage] = at
        at += weight / total
    reached = 0

    def progress(stage: str, fraction: float) -> None:
        nonlocal reached
        fraction = min(max(fraction, 0.0), 1.0)
        if stage in SUBSTAGES:
            stage, lo, hi = SUBSTAGES[stage]
            fraction = lo + (hi - lo) * fraction
        share = weights.get(stage, 0.0) / total
        done = start.get(stage, 0.0) + share * fraction
        reached = max(reached, int(99 * done))
        report(reached, STAGE_WORDS.get(stage, stage))

    return progress


def _no_progress(stage: str, fraction: float) -> None:
    del stage, fraction


def _never() -> bool:
    return False


def assess_mesh(
    mesh: Mesh,
    smoothing: SmoothingParams | None = None,
    *,
    fitness: NDArray[np.float64] | None = None,
    boundary: NDArray[np.bool_] | None = None,
) -> Snapshot:
    """Per-triangle quality, per-node fitness and the summary of ``mesh``.

    ``fitness`` (the node fitness by ``smoothing.fitness``) and ``boundary`` (the mesh's
    boundary nodes) are computed unless given: a smoother that kept the exact fitness of
    the nodes it moved, and a mesh of the same connectivity as one assessed before, spare
    the final assessment that work.

    >>> from engine.mesh import Mesh
    >>> pts = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    >>> snap = assess_mesh(Mesh(pts, np.array([[0, 1, 2]])))
    >>> round(snap.summary["quality"]["min"], 6), snap.fitness.round(6).tolist()
    (1.0, [1.0, 1.0, 1.0])
    """
    s = smoothing or SmoothingParams()
    q = triangle_quality(mesh)
    fit = node_fitness(mesh, s.fitness, s.alpha, s.beta) if fitness is None else fitness
    summary: dict[str, Any] = summarize(q)
    summary["points"] = mesh.n_points
    movable = ~(mesh.boundary_nodes if boundary is None else boundary)
    inner = fit[movable]
    summary["fitness"] = {
        "function": s.fitness,
        "min": float(inner.min()) if inner.size else None,
        "mean": float(inner.mean()) if inner.size else None,
    }
    return Snapshot(mesh=mesh, quality=q, fitness=fit, summary=summary)


def mesh_region(
    region: Region,
    sizing: SizingParams,
    relax_sweeps: int = 3,
    should_stop: StopFn | None = None,
    max_triangles: int = 5_000_000,
    progress: ProgressFn | None = None,
    *,
    held_sides: Collection[tuple[float, float, float, float]] = (),
) -> tuple[Mesh, dict[str, float]]:
    """Mesh ``region`` (no swapping, no smoothing); returns the mesh and stage timings.

    The mesher is the advancing front followed by ``relax_sweeps`` sweeps of constrained
    relaxation, edge collapses where fronts left a node too many
    (:func:`engine.collapse.collapse_edges`), a node in each wedge-spanning triangle where
    that helps (:func:`engine.spanning.split_spanning`, which may also split boundary sides),
    boundary slides (:mod:`engine.slide`) and relaxation again (0 gives the raw front).
    Raises :class:`LimitExceeded` when the estimated (or, while meshing, the actual) triangle
    count is over ``max_triangles``; every stage polls ``should_stop`` and reports ``progress``
    (stages ``sizing``, ``estimate``, ``discretize``, ``front``, ``relax``, ``collapse``).
    With ``sizing.resample`` the rings are resampled first (:mod:`engine.resample`), so the
    field and the estimate see the resampled boundary. No stage splits a boundary segment in
    ``held_sides`` (by its ends' coordinates ``(ax, ay, bx, by)``, either way: a subdomain's
    pieces of shared edges, split once for both sides), and after the discretisation no
    stage removes a boundary node: the side splits add some, and the slides move a node inside
    an input segment along it (never an input vertex, nor a node of a side in ``held_sides``).
    """
    progress = progress or _no_progress
    should_stop = should_stop or _never
    t0 = time.perf_counter()
    if sizing.resample:
        region = resample_region(region, sizing).region
    refuse_by_area(region, sizing, max_triangles)
    field = build_size_field(region, sizing, progress, should_stop)
    estimate = estimate_triangles(
        region, field, cap=max_triangles, progress=progress, should_stop=should_stop
    )
    if estimate > max_triangles:
        raise LimitExceeded(
            f"the mesh would have about {estimate} triangles, over the limit of {max_triangles}; "
            "use a larger size",
            limit=max_triangles,
            estimate=estimate,
        )
    nodes = discretize(region, field, progress, should_stop, held=held_sides)
    t1 = time.perf_counter()
    progress("front", 0.0)
    front = advance_front(nodes, field, should_stop, max_triangles=max_triangles)
    progress("relax", 0.0)
    mesh = relax(front, relax_sweeps, should_stop=should_stop)
    if relax_sweeps > 0:  # 0 asks for the raw front
        progress("collapse", 0.0)
        collapsed = split_spanning(collapse_edges(mesh, should_stop=should_stop), held=held_sides)
        inputs = {(float(x), float(y)) for ring in region.rings for x, y in ring}
        for _ in range(SLIDE_ROUNDS):
            slid = slide_round(collapsed, inputs, held_sides)
            if slid is None:
                break
            collapsed = slid
        progress("relax", 0.5)
        mesh = relax(collapsed, relax_sweeps, should_stop=should_stop)
    progress("relax", 1.0)
    t2 = time.perf_counter()
    return mesh, {"boundary": t1 - t0, "mesh": t2 - t1}


def _worst(points: NDArray[np.float64], triangles: NDArray[np.int64]) -> float:
    return float(shape_quality(points, triangles).min())


def _check_method(smoothing: SmoothingParams) -> None:
    if smoothing.method not in SMOOTHERS:
        raise ValueError(
            f"unknown smoothing method {smoothing.method!r}; choose one of {sorted(SMOOTHERS)}"
        )


def improve_mesh(
    initial: Mesh,
    smoothing: SmoothingParams,
    swap: bool,
    rng: np.random.Generator,
    progress: ProgressFn,
    should_stop: StopFn,
    timings: dict[str, float],
    parameters: dict[str, Any],
    started: float,
    *,
    locked: NDArray[np.int64] | None = None,
) -> Result:
    """Swap (diagonals, then valence), smooth and assess ``initial``, as
    :func:`mesh_then_smooth` does after meshing: ``timings`` (the mesher's) gains ``swap``,
    ``smooth`` and ``total`` (since ``started``). The ``locked`` edges never flip and
    ``initial.boundary_nodes`` never move; the intermediate meshes keep ``initial``'s class (a
    :class:`~engine.constraints.PinnedMesh` keeps its pins)."""
    first = assess_mesh(initial, smoothing)
    t = time.perf_counter()
    if should_stop():
        raise Cancelled("stopped before swapping")
    progress("swap", 0.0)
    relax = smoothing.method != "none"  # settle displaced nodes before deciding flips
    swapped_mesh = initial
    if swap:
        flipped = swap_diagonals(initial, locked, relax=relax)
        swapped = replace(initial, points=flipped.points, triangles=flipped.triangles)
        swapped_mesh = keeps_boundary(swapped, initial)
    progress("swap", 1.0)
    timings["swap"] = time.perf_counter() - t
    t = time.perf_counter()
    if should_stop():
        raise Cancelled("stopped before smoothing")
    progress("smooth", 0.0)
    regular = regularise_valence(swapped_mesh, locked) if swap and relax else None
    if regular is not None:
        regular = replace(initial, points=regular.points, triangles=regular.triangles)
        regular = keeps_boundary(regular, initial)
    if regular is None:
        outcome = smooth_points(swapped_mesh, smoothing, rng, progress, should_stop)
    else:
        # Valence flips may pass through a worse triangle for the smoother to lift. Keep them
        # when the smoothed worst is no worse than the swapped mesh's; otherwise smooth the
        # swapped mesh as it was and keep the better of the two.
        outcome = smooth_points(regular, smoothing, rng, progress, should_stop)
        worst = _worst(outcome.points, regular.triangles)
        if worst < _worst(swapped_mesh.points, swapped_mesh.triangles):
            plain = smooth_points(swapped_mesh, smoothing, rng, progress, should_stop)
            if _worst(plain.points, swapped_mesh.triangles) > worst:
                outcome, regular = plain, None
        if regular is not None:
            swapped_mesh = regular
    if smoothing.method != "none":  # a last settling for the mean, never worse at the worst
        settled = relax_mean(keeps_boundary(swapped_mesh.with_points(outcome.points), initial))
        if not np.array_equal(settled.points, outcome.points):  # the GA's fitness is stale
            outcome = replace(outcome, points=settled.points, fitness=None)
    # Assessed once, when it is known which mesh the smoother kept (unchanged: not again).
    second = first if swapped_mesh is initial else assess_mesh(swapped_mesh, smoothing)
    progress("smooth", 1.0)
    timings["smooth"] = time.perf_counter() - t
    unmoved = np.array_equal(outcome.points, swapped_mesh.points)
    final = second
    if not unmoved:
        moved = swapped_mesh.with_points(outcome.points)
        # Same connectivity and class: the same boundary, known already.
        boundary = swapped_mesh.boundary_nodes
        final = assess_mesh(moved, smoothing, fitness=outcome.fitness, boundary=boundary)
    timings["total"] = time.perf_counter() - started
    return Result(
        initial=first,
        swapped=second,
        smoothed=final,
        history=outcome.history,
        parameters=parameters,
        timings=timings,
    )


def mesh_then_smooth(
    region: Region,
    params: PipelineParams,
    rng: np.random.Generator | None = None,
    progress: ProgressFn | None = None,
    should_stop: StopFn | None = None,
) -> Result:
    """Mesh ``region``, swap diagonals, smooth interior nodes; report every stage.

    >>> from engine.boundary import make_region
    >>> square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    >>> params = PipelineParams(SizingParams(size=0.25), smoothing=SmoothingParams(method="none"))
    >>> result = mesh_then_smooth(square, params, np.random.default_rng(0))
    >>> result.smoothed.summary["inverted"], sorted(result.timings)
    (0, ['boundary', 'mesh', 'smooth', 'swap', 'total'])
    """
    progress = progress or _no_progress
    should_stop = should_stop or _never
    rng = rng if rng is not None else np.random.default_rng(0)
    _check_method(params.smoothing)
    started = time.perf_counter()
    progress("boundary", 0.0)
    sizing, boundary = params.sizing, None
    if sizing.resample:  # here rather than in mesh_region, to report the deviation
        resampled = resample_region(region, sizing)
        region, sizing, boundary = resampled.region, replace(sizing, resample=False), resampled
    mesh, timings = mesh_region(
        region, sizing, params.relax, should_stop, params.max_triangles, progress
    )
    progress("mesh", 1.0)
    result = improve_mesh(
        mesh, params.smoothing, params.swap, rng, progress, should_stop, timings,
        params.to_dict(), started,
    )  # fmt: skip
    if boundary is not None:
        result.smoothed.summary["boundary"] = boundary.summary()
    return result


def smooth_mesh(
    mesh: Mesh,
    smoothing: SmoothingParams,
    swap: bool = True,
    rng: np.random.Generator | None = None,
    progress: ProgressFn | None = None,
    should_stop: StopFn | None = None,
) -> Result:
    """Swap and smooth an existing mesh; boundary nodes stay fixed."""
    progress = progress or _no_progress
    should_stop = should_stop or _never
    rng = rng if rng is not None else np.random.default_rng(0)
    _check_method(smoothing)
    started = time.perf_counter()
    timings = {"boundary": 0.0, "mesh": 0.0}
    parameters = {"swap": swap, "smoothing": asdict(smoothing)}
    return improve_mesh(
        mesh, smoothing, swap, rng, progress, should_stop, timings, parameters, started
    )
