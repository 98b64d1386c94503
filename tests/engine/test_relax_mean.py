"""Relaxation for the mean radius ratio: never a worse worst, never a lower mean, still valid."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings

from engine import PipelineParams, SizingParams, make_region, mesh_then_smooth
from engine.mesh import Mesh
from engine.quality import radius_ratio, shape_quality
from engine.relax import relax, relax_mean

from .random_meshes import meshes


@settings(max_examples=60, deadline=None)
@given(meshes())
def test_relax_mean_keeps_the_worst_and_raises_the_mean(mesh: Mesh) -> None:
    settled = relax_mean(mesh)
    before = radius_ratio(mesh.points, mesh.triangles)
    after = radius_ratio(settled.points, settled.triangles)
    assert np.all(settled.areas > 0)
    assert np.array_equal(settled.points[mesh.boundary_nodes], mesh.points[mesh.boundary_nodes])
    assert after.min() >= min(before.min(), 0.8) - 1e-12
    shape_before = shape_quality(mesh.points, mesh.triangles).min()
    assert shape_quality(settled.points, settled.triangles).min() >= min(shape_before, 0.8) - 1e-12
    assert after.mean() >= before.mean() - 1e-12


def _graded_band() -> Mesh:
    # A region whose boundary is divided four times finer than the size: the mesh grades up
    # from it, the band where the worst-guarded relaxation leaves the mean behind gmsh's.
    t = np.linspace(0, 2 * np.pi, 120, endpoint=False)
    r = 1.0 + 0.2 * np.sin(3 * t)
    region = make_region([(np.c_[r * np.cos(t), r * np.sin(t)], [])])
    params = PipelineParams(SizingParams(size=0.2))
    return mesh_then_smooth(region, params, np.random.default_rng(0)).swapped.mesh


def test_relax_mean_lifts_a_graded_band_beyond_relax() -> None:
    mesh = _graded_band()
    plain = relax(mesh, 3)
    settled = relax_mean(mesh)
    q_plain = radius_ratio(plain.points, plain.triangles)
    q_settled = radius_ratio(settled.points, settled.triangles)
    assert q_settled.mean() > q_plain.mean() + 1e-3
    assert q_settled.min() >= min(radius_ratio(mesh.points, mesh.triangles).min(), 0.8)
