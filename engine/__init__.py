"""evomesh engine: pure numerics for meshing a planar region and smoothing the mesh.

Arrays in, frozen dataclasses out; no web, storage or logging configuration here.

>>> import numpy as np
>>> import engine
>>> region = engine.make_region([([[0, 0], [2, 0], [2, 1], [0, 1]], [])])
>>> smoothing = engine.SmoothingParams("none")
>>> params = engine.PipelineParams(engine.SizingParams(size=0.5), smoothing=smoothing)
>>> result = engine.mesh_then_smooth(region, params, np.random.default_rng(7))
>>> result.smoothed.summary["inverted"]
0
"""

from __future__ import annotations

from .boundary import PolygonPart, Region, make_region
from .constraints import Constrained, InvalidConstraint, check_constraints, mesh_with_constraints
from .errors import (
    Cancelled,
    EngineError,
    InvalidBoundary,
    InvalidMesh,
    LimitExceeded,
    MeshingError,
)
from .estimate import estimate_triangles
from .fitness import FITNESS, node_fitness
from .mesh import Mesh, validate_mesh
from .params import PipelineParams, SizingParams, SmoothingParams
from .pipeline import assess_mesh, mesh_region, mesh_then_smooth, smooth_mesh
from .quality import METRICS, Metric, TriangleQuality, register_metric, summarize, triangle_quality
from .refinement import Refinement
from .resample import Resampled, resample_region
from .result import ProgressFn, Result, SmoothOutcome, Snapshot, StopFn, SweepStats
from .smoothing import SMOOTHERS
from .subdomains import Subdomains, mesh_subdomains
from .tags import MeshTags, Tagging, TagRun, tag_mesh
from .warm import warmup

__all__ = [
    "FITNESS",
    "METRICS",
    "SMOOTHERS",
    "Cancelled",
    "Constrained",
    "EngineError",
    "InvalidBoundary",
    "InvalidConstraint",
    "InvalidMesh",
    "LimitExceeded",
    "Mesh",
    "MeshTags",
    "MeshingError",
    "Metric",
    "PipelineParams",
    "PolygonPart",
    "ProgressFn",
    "Refinement",
    "Region",
    "Resampled",
    "Result",
    "SizingParams",
    "SmoothOutcome",
    "SmoothingParams",
    "Snapshot",
    "StopFn",
    "Subdomains",
    "SweepStats",
    "TagRun",
    "Tagging",
    "TriangleQuality",
    "assess_mesh",
    "check_constraints",
    "estimate_triangles",
    "make_region",
    "mesh_region",
    "mesh_subdomains",
    "mesh_then_smooth",
    "mesh_with_constraints",
    "node_fitness",
    "register_metric",
    "resample_region",
    "smooth_mesh",
    "summarize",
    "tag_mesh",
    "triangle_quality",
    "validate_mesh",
    "warmup",
]
