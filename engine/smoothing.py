"""Smoother registry: name -> function moving interior nodes of a mesh."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .ga import ga_smooth
from .laplacian import laplacian_smooth, smart_laplacian_smooth
from .mesh import Mesh
from .params import SmoothingParams
from .result import ProgressFn, SmoothOutcome, StopFn

__all__ = ["SMOOTHERS", "Smoother", "smooth_points"]

#: ``smoother(mesh, params, rng, progress, should_stop) -> SmoothOutcome``; boundary nodes fixed.
Smoother = Callable[[Mesh, SmoothingParams, np.random.Generator, ProgressFn, StopFn], SmoothOutcome]


def _none(
    mesh: Mesh,
    params: SmoothingParams,
    rng: np.random.Generator,
    progress: ProgressFn,
    should_stop: StopFn,
) -> SmoothOutcome:
    return SmoothOutcome(points=mesh.points.copy())


SMOOTHERS: dict[str, Smoother] = {
    "none": _none,
    "laplacian": laplacian_smooth,
    "smart-laplacian": smart_laplacian_smooth,
    "ga": ga_smooth,
}


def smooth_points(
    mesh: Mesh,
    params: SmoothingParams,
    rng: np.random.Generator,
    progress: ProgressFn,
    should_stop: StopFn,
) -> SmoothOutcome:
    """Run the smoother named by ``params.method``."""
    try:
        smoother = SMOOTHERS[params.method]
    except KeyError:
        raise ValueError(
            f"unknown smoothing method {params.method!r}; choose one of {sorted(SMOOTHERS)}"
        ) from None
    return smoother(mesh, params, rng, progress, should_stop)
