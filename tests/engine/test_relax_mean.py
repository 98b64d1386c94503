"""Relaxation for the mean radius ratio: never a worse worst, never a lower mean, still valid."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from engine import PipelineParams, SizingParams, SmoothingParams, make_region, mesh_then_smooth
from engine.mesh import Mesh
from engine.quality import radius_ratio, shape_quality
from engine.relax import relax, relax_mean

from .random_meshes import meshes


@settings(max_examples=60, deadline=None)
@given(meshes())
def test_relax_mean_keeps_the_worst_and_raises_the_mean(mesh: Mesh) -> None:
    before, after = _settle(mesh)
    assert after.mean() >= before.mean() - 1e-12


def _settle(mesh: Mesh) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The radius ratios before and after :func:`relax_mean`, once the settled mesh is checked:
    valid, boundary unmoved, worst radius ratio and worst shape quality no lower."""
    settled = relax_mean(mesh)
    before = radius_ratio(mesh.points, mesh.triangles)
    after = radius_ratio(settled.points, settled.triangles)
    assert np.all(settled.areas > 0)
    assert np.array_equal(settled.points[mesh.boundary_nodes], mesh.points[mesh.boundary_nodes])
    assert after.min() >= before.min() - 1e-12
    shape_before = shape_quality(mesh.points, mesh.triangles).min()
    assert shape_quality(settled.points, settled.triangles).min() >= shape_before - 1e-12
    return before, after


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


def test_the_ascent_lifts_a_graded_band_beyond_the_centroid_alone() -> None:
    mesh = _graded_band()
    centroid = relax_mean(mesh, sweeps=3, iterations=0)
    settled = relax_mean(mesh)
    q_centroid = radius_ratio(centroid.points, centroid.triangles)
    q_settled = radius_ratio(settled.points, settled.triangles)
    assert q_settled.mean() > q_centroid.mean() + 5e-4
    assert q_settled.min() >= min(radius_ratio(mesh.points, mesh.triangles).min(), 0.8)


@st.composite
def wobbly_bands(draw: st.DrawFn) -> Mesh:
    """A wobbly ring divided finer than the size (the mesh grades up from it), swapped and
    not smoothed: a graded band as the settling step meets it."""
    n = draw(st.integers(30, 60))
    waves = draw(st.integers(2, 5))
    amplitude = draw(st.floats(0.05, 0.25))
    noise = np.random.default_rng(draw(st.integers(0, 2**16))).normal(0, 0.02, n)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = 1.0 + amplitude * np.sin(waves * t) + noise
    ring = np.c_[r * np.cos(t), r * np.sin(t)]
    spacing = float(np.median(np.hypot(*np.diff(ring, axis=0).T)))
    size = spacing * draw(st.floats(2.0, 4.0))
    params = PipelineParams(SizingParams(size=size), smoothing=SmoothingParams(method="none"))
    region = make_region([(ring, [])])
    return mesh_then_smooth(region, params, np.random.default_rng(0)).swapped.mesh


@settings(max_examples=12, deadline=None)
@given(wobbly_bands())
def test_relax_mean_on_graded_bands_keeps_the_worst_and_raises_the_mean(mesh: Mesh) -> None:
    before, after = _settle(mesh)
    assert after.mean() > before.mean()
