"""The graded size field: short segments, narrow gaps and sharp corners ask for smaller sizes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import SizingParams, make_region, mesh_region, triangle_quality
from engine.boundary import Region
from engine.discretize import discretize
from engine.gaps import gap_search, gap_widths, ring_segments
from engine.sizing import GAP_FACTOR, build_size_field

from .control_strategies import valid_regions
from .regions import assert_conforming


def test_uniform_away_from_features() -> None:
    region = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    field = build_size_field(region, SizingParams(size=0.1))
    pts = np.random.default_rng(0).uniform(0, 1, (100, 2))
    np.testing.assert_allclose(field(pts), 0.1)


def test_short_segment_grades_with_growth() -> None:
    region = make_region([([[0, 0], [1, 0], [1, 0.001], [1, 1], [0, 1]], [])])
    field = build_size_field(region, SizingParams(size=0.1, growth=1.2))
    d = np.array([0.0, 0.01, 0.1, 0.6])
    h = field(np.c_[1.0 - d, np.zeros_like(d)])
    assert h[0] == pytest.approx(0.001)
    assert np.all(np.diff(h) > 0)
    # Never faster than growth: h(x) <= h_feature + (growth - 1) * distance.
    assert np.all(h <= 0.001 + 0.2 * d + 1e-12)
    assert h[-1] == pytest.approx(0.1)


def test_narrow_channel_gets_rows_across() -> None:
    width = 0.02
    region = make_region([([[0, 0], [1, 0], [1, width], [0, width]], [])])
    field = build_size_field(region, SizingParams(size=0.1))
    wall, mid = field(np.array([[0.5, 0.0], [0.5, width / 2]]))
    assert wall <= GAP_FACTOR * width * (1 + 0.2 / 2)  # samples are at most a size apart
    assert mid <= GAP_FACTOR * width + 0.2 * np.hypot(width / 2, GAP_FACTOR * width / 2)
    mesh, _ = mesh_region(region, SizingParams(size=0.1))
    assert_conforming(mesh, region)
    interior = ~mesh.boundary_nodes
    assert interior.sum() > 20  # more than one row of triangles across


def test_dumbbell_neck_is_refined_and_valid() -> None:
    outer = [[0, 0], [1, 0], [1, 0.48], [1.5, 0.48], [1.5, 0], [2.5, 0], [2.5, 1], [1.5, 1],
             [1.5, 0.52], [1, 0.52], [1, 1], [0, 1]]  # fmt: skip
    region = make_region([(outer, [])])
    mesh, _ = mesh_region(region, SizingParams(size=0.1))
    assert_conforming(mesh, region)
    c = mesh.points[mesh.triangles].mean(axis=1)
    neck = (c[:, 0] > 1.05) & (c[:, 0] < 1.45)
    assert np.sqrt(2 * mesh.areas[neck].max()) < 0.04


def test_sharp_corner_shrinks_the_tip_size() -> None:
    angle = np.radians(10.0)
    region = make_region([([[0, 0], [1, 0], [np.cos(angle), np.sin(angle)]], [])])
    field = build_size_field(region, SizingParams(size=0.1))
    assert field(np.array([[0.0, 0.0]]))[0] <= 0.1 * 10 / 60 * 1.01
    mesh, _ = mesh_region(region, SizingParams(size=0.1))
    assert_conforming(mesh, region)
    assert triangle_quality(mesh).min_angle.min() >= 0.5 * 10.0


def test_discretisation_keeps_input_vertices_and_splits_evenly() -> None:
    region = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    field = build_size_field(region, SizingParams(size=0.3))
    boundary = discretize(region, field)
    lengths = np.hypot(
        *(boundary.points[boundary.edges[:, 1]] - boundary.points[boundary.edges[:, 0]]).T
    )
    np.testing.assert_allclose(lengths, 1 / 3)  # round(1 / 0.3) = 3 equal pieces per side
    for corner in [[0, 0], [1, 0], [1, 1], [0, 1]]:
        assert np.any(np.all(boundary.points == corner, axis=1))


def _facing_brute_force(
    region: Region, seg: np.ndarray, t: np.ndarray, reach: np.ndarray
) -> np.ndarray:
    """Gap widths by comparing every sample with every segment (what the tree must find)."""
    a, b, prev, nxt = ring_segments(region)
    d = b - a
    n_seg = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.hypot(d[:, 0], d[:, 1])[:, None]
    p = a[seg] + t[:, None] * d[seg]
    u = np.clip(np.einsum("ijk,jk->ij", p[:, None] - a[None], d) / (d * d).sum(1), 0, 1)
    v = a[None] + u[..., None] * d[None] - p[:, None]
    dist = np.hypot(v[..., 0], v[..., 1])
    facing = (np.einsum("ijk,ik->ij", v, n_seg[seg]) > 0.5 * dist) & (
        np.einsum("ijk,jk->ij", -v, n_seg) > 0.5 * dist
    )
    cols = np.arange(len(a))[None]
    own = seg[:, None]
    adjacent = (cols == own) | (cols == prev[own]) | (cols == nxt[own])
    ok = facing & ~adjacent & (dist > 0) & (dist <= reach[:, None])
    return np.where(ok, GAP_FACTOR * dist, np.inf).min(axis=1)


@settings(max_examples=25, deadline=None)
@given(case=valid_regions(), seed=st.integers(0, 2**32 - 1))
def test_the_gap_search_finds_what_all_pairs_find(case: tuple[Region, float], seed: int) -> None:
    region, size = case
    vertex_field = build_size_field(region, SizingParams(size=size))
    search = gap_search(region, vertex_field.tree, GAP_FACTOR)
    rng = np.random.default_rng(seed)
    seg = rng.integers(0, len(search.a), 300)
    t = rng.uniform(0, 1, 300)
    got = gap_widths(search, seg, t)
    pts = search.a[seg] + t[:, None] * (search.b[seg] - search.a[seg])
    want = _facing_brute_force(region, seg, t, vertex_field(pts) / GAP_FACTOR)
    np.testing.assert_array_equal(got, want)
