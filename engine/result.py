"""What the pipeline returns: frozen snapshots of each stage and the smoothing history."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .mesh import Mesh
from .quality import TriangleQuality

__all__ = ["ProgressFn", "Result", "SmoothOutcome", "Snapshot", "StopFn", "SweepStats"]

FloatArray = NDArray[np.float64]
#: ``progress(stage, fraction)``: stage is "boundary", "mesh", "swap", "smooth"; fraction in [0, 1].
ProgressFn = Callable[[str, float], None]
#: ``should_stop() -> bool``: polled between GA generations and between stages.
StopFn = Callable[[], bool]


@dataclass(frozen=True)
class Snapshot:
    """A mesh at one stage with its per-triangle figures, per-node fitness and summary."""

    mesh: Mesh
    quality: TriangleQuality
    fitness: FloatArray  #: (n,) per-node fitness in [0, 1]
    summary: dict[str, Any]  #: see :func:`engine.quality.summarize`, plus node fitness figures


@dataclass(frozen=True)
class SweepStats:
    """One smoothing sweep."""

    sweep: int  #: 1-based
    mean_fitness: float  #: mean node fitness after the sweep (movable nodes)
    min_fitness: float  #: smallest node fitness after the sweep (movable nodes)
    max_change: float  #: largest fitness change of a node during the sweep
    nodes_evolved: int  #: node-GAs run (or nodes visited by a Laplacian sweep)
    nodes_moved: int  #: nodes whose position changed
    seconds: float  #: wall time of the sweep


@dataclass(frozen=True)
class SmoothOutcome:
    """What a smoother returns: new positions (same connectivity) and its sweep history."""

    points: FloatArray
    history: tuple[SweepStats, ...] = ()
    #: The exact node fitness (the smoothing's fitness function) at ``points``, when the
    #: smoother keeps it (the GA does), so that the final assessment need not compute it again.
    fitness: FloatArray | None = None


@dataclass(frozen=True)
class Result:
    """The outcome of :func:`engine.mesh_then_smooth` or :func:`engine.smooth_mesh`."""

    initial: Snapshot  #: as meshed (or as given, for smooth_mesh)
    swapped: Snapshot  #: after diagonal swapping (same as initial when swapping is off)
    smoothed: Snapshot  #: final
    history: tuple[SweepStats, ...]  #: smoothing sweeps
    parameters: dict[str, Any]  #: the parameters used, as plain JSON
    timings: dict[str, float] = field(default_factory=dict)  #: seconds per stage and "total"
