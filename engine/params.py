"""Parameters of the pipeline stages, as frozen dataclasses with the documented defaults."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

from .refinement import Refinement

__all__ = ["SELECTIONS", "PipelineParams", "SizingParams", "SmoothingParams"]

#: The GA's node selections (:mod:`engine.ga`): "poor" is the default, "all" the paper's.
SELECTIONS = ("poor", "all")


@dataclass(frozen=True)
class SizingParams:
    """Target edge length and its grading.

    >>> SizingParams(size=0.1).growth
    1.2
    """

    size: float  #: target edge length in the interior
    growth: float = 1.2  #: largest size ratio between neighbouring elements
    size_min: float | None = None  #: lower clamp of the local size
    size_max: float | None = None  #: upper clamp of the local size
    #: Local sizes on geometries (:mod:`engine.refinement`), combined with the rest by the minimum.
    refinements: tuple[Refinement, ...] = ()
    #: Re-discretise digitised rings to the local size before meshing (:mod:`engine.resample`)
    #: instead of keeping every input vertex; corners stay.
    resample: bool = False
    #: Largest distance of the resampled boundary from the input; None: 0.1 of the local size.
    resample_tolerance: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.size) and self.size > 0):
            raise ValueError(f"size must be a positive number, got {self.size}")
        if not (math.isfinite(self.growth) and self.growth > 1.0):
            raise ValueError(f"growth must be a number greater than 1, got {self.growth}")
        for name in ("size_min", "size_max"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v}")
        if self.resample_tolerance is not None and not (
            math.isfinite(self.resample_tolerance) and self.resample_tolerance > 0
        ):
            raise ValueError(
                f"resample_tolerance must be a positive number, got {self.resample_tolerance}"
            )
        if (
            self.size_min is not None
            and self.size_max is not None
            and self.size_min > self.size_max
        ):
            raise ValueError("size_min must not exceed size_max")


@dataclass(frozen=True)
class SmoothingParams:
    """Which smoother runs, and the genetic algorithm's parameters.

    The GA parameters default to the paper's; the fitness defaults to ``capped`` (measured
    best, see :mod:`engine.fitness`). Out-of-range numbers raise ``ValueError``.

    >>> SmoothingParams(population=1)
    Traceback (most recent call last):
    ...
    ValueError: population must be an integer of at least 2, got 1
    """

    method: str = "ga"  #: a key of ``engine.smoothing.SMOOTHERS``
    fitness: str = "capped"  #: a key of ``engine.fitness.FITNESS`` (the paper's is "combined")
    alpha: float = 0.8  #: weight of the angle term in ``combined``
    beta: float = 0.2  #: weight of the aspect-ratio term in ``combined``
    population: int = 100  #: candidate positions per node
    generations: int = 50  #: generations per node-GA
    crossover_rate: float = 0.8  #: probability of one-point crossover per pair
    mutation_rate: float = 0.15  #: probability of replacing each gene
    #: A node's GA stops early once its best fitness has gained no more than 1e-4 in this many
    #: generations (:data:`engine.ga_kernels.STALL_GAIN`); None runs every generation.
    patience: int | None = 15
    tolerance: float = 0.01  #: stop when a sweep's largest fitness change is below this
    max_sweeps: int = 20  #: upper bound on GA sweeps
    iterations: int = 10  #: sweeps of the Laplacian baselines
    threshold: float | None = None  #: evolve only nodes whose fitness is below this
    #: Which nodes the GA evolves: "poor" (nodes of a triangle with shape quality below
    #: ``poor_quality``, see :mod:`engine.ga`) or "all" (every interior node).
    selection: str = "poor"
    poor_quality: float = 0.9  #: shape quality below which a triangle is poorly shaped

    def __post_init__(self) -> None:
        if self.patience is not None and (
            isinstance(self.patience, bool) or not isinstance(self.patience, int)
            or self.patience < 1
        ):  # fmt: skip
            raise ValueError(
                f"patience must be None or an integer of at least 1, got {self.patience}"
            )
        for name in ("population", "generations", "max_sweeps", "iterations"):
            low = 2 if name == "population" else 1
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < low:
                raise ValueError(f"{name} must be an integer of at least {low}, got {v}")
        for name in ("crossover_rate", "mutation_rate"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0.0 <= v <= 1.0):
                raise ValueError(f"{name} must be within [0, 1], got {v}")
        if not (
            math.isfinite(self.alpha) and math.isfinite(self.beta) and self.alpha >= 0
            and self.beta >= 0 and self.alpha + self.beta > 0
        ):  # fmt: skip
            raise ValueError(
                f"alpha and beta must be non-negative with a positive sum, got "
                f"{self.alpha} and {self.beta}"
            )
        if not (math.isfinite(self.tolerance) and self.tolerance >= 0):
            raise ValueError(f"tolerance must be a non-negative number, got {self.tolerance}")
        if self.selection not in SELECTIONS:
            raise ValueError(f"selection must be one of {list(SELECTIONS)}, got {self.selection!r}")
        if not (math.isfinite(self.poor_quality) and 0.0 <= self.poor_quality <= 1.0):
            raise ValueError(f"poor_quality must be within [0, 1], got {self.poor_quality}")
        if self.threshold is not None and not math.isfinite(self.threshold):
            raise ValueError(f"threshold must be a number, got {self.threshold}")


@dataclass(frozen=True)
class PipelineParams:
    """Everything ``mesh_then_smooth`` needs besides the region and the random generator."""

    sizing: SizingParams
    #: Sweeps of the mesher's constrained relaxation (:mod:`engine.relax`); 0 = raw front.
    relax: int = 3
    swap: bool = True
    #: Refuse (``LimitExceeded``) regions whose estimated mesh is larger than this.
    max_triangles: int = 5_000_000
    smoothing: SmoothingParams = field(default_factory=SmoothingParams)

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form, stored in results."""
        return asdict(self)
