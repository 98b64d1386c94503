"""Warm-up: compile (or load from numba's cache) every kernel a job calls, before the first job.

Separate from :mod:`engine.pipeline` because it also runs a job with constraints
(:mod:`engine.constraints`, which builds on the pipeline).
"""

from __future__ import annotations

from .boundary import make_region
from .constraints import mesh_with_constraints
from .mesh import validate_mesh
from .params import PipelineParams, SizingParams, SmoothingParams
from .pipeline import mesh_region, mesh_then_smooth
from .smoothing import SMOOTHERS

__all__ = ["compiled_kernels", "warmup"]


def compiled_kernels() -> dict[str, int]:
    """Every numba kernel of the engine (``"engine.module.name"``) and how many compiled
    signatures it holds in this process (kernels inlined into others hold none)."""
    import importlib
    import pkgutil

    from numba.core.registry import CPUDispatcher

    package = importlib.import_module(__name__.rpartition(".")[0])
    out: dict[str, int] = {}
    for info in pkgutil.walk_packages(package.__path__, f"{package.__name__}."):
        module = importlib.import_module(info.name)
        for name, obj in vars(module).items():
            if isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == module.__name__:
                out[f"{module.__name__}.{name}"] = len(obj.signatures)
    return out


def warmup() -> tuple[str, ...]:
    """Run every stage and every smoother once on a tiny region so that numba compiles (or
    loads from its cache) each kernel a job calls; returns the names of the engine's kernels
    now compiled (see :func:`compiled_kernels`).

    The GA runs with ``selection="all"``: the tiny mesh has no poor triangle, and with the
    default selection the GA's kernels would be left for the first job to compile. A 37-degree
    spike whose legs end at input vertices at unequal distances is meshed too: its corner gets
    an interior node and nodes on its sides (:mod:`engine.spanning`, :mod:`engine.sides`); its
    mesh is validated as a smooth job's input is, and a line and a point are put into a mesh as
    a job with constraints does.
    """
    region = make_region(
        [([[0, 0], [1, 0], [1, 1], [0, 1]], [[[0.4, 0.4], [0.6, 0.4], [0.5, 0.6]]])]
    )
    for method in SMOOTHERS:
        smoothing = SmoothingParams(
            method=method, population=8, generations=2, max_sweeps=1, selection="all"
        )
        mesh_then_smooth(region, PipelineParams(SizingParams(0.2), smoothing=smoothing))
    spike = [[0.0, 0.0], [0.23, -0.077], [0.23, -0.5], [1.0, -0.5], [1.0, 0.5]]
    spike += [[0.265, 0.5], [0.265, 0.089]]
    mesh, _ = mesh_region(make_region([(spike, [])]), SizingParams(0.2))
    validate_mesh(mesh.points, mesh.triangles)  # what a smooth or quality job checks first
    line = {"type": "LineString", "coordinates": [[0.1, 0.15], [0.9, 0.25]]}
    point = {"type": "Point", "coordinates": [0.8, 0.8]}
    mesh_with_constraints(region, PipelineParams(SizingParams(0.2)), [line, point])
    return tuple(sorted(name for name, count in compiled_kernels().items() if count))
