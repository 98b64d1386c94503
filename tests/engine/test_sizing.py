"""The graded size field: short segments, narrow gaps and sharp corners ask for smaller sizes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import LimitExceeded, SizingParams, make_region, mesh_region, triangle_quality
from engine.boundary import Region
from engine.discretize import discretize
from engine.gaps import gap_search, gap_widths, ring_segments
from engine.sizing import GAP_FACTOR, RESOLUTION_STEPS, build_size_field

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


def test_a_size_far_below_the_boundary_length_is_refused_before_sampling_it() -> None:
    # 8e9 gap samples at this size: refused from the segment lengths, before any array of
    # samples is made (the arrays once asked for 60 GiB).
    square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    with pytest.raises(LimitExceeded, match="boundary samples") as info:
        build_size_field(square, SizingParams(size=1e-9))
    assert info.value.estimate >= 8_000_000_000


@pytest.mark.parametrize(("offset", "side"), [(1e9, 1e-6), (1e5, 1e-10)])
def test_a_size_the_coordinates_cannot_resolve_is_refused_saying_where(
    offset: float, side: float
) -> None:
    # A square 1e-6 wide at 1e9 meshed at 1e-7: coordinates there step by 1.2e-7, and the front
    # once failed on coincident points (ZeroDivisionError).
    ring = offset + side * np.array([[0, 0], [1, 0], [1, 1], [0, 1]])
    with pytest.raises(LimitExceeded, match="resolved only to") as info:
        mesh_region(make_region([(ring, [])]), SizingParams(size=side / 10))
    assert info.value.estimate < RESOLUTION_STEPS


def test_a_feature_the_coordinates_cannot_resolve_is_refused_at_its_place() -> None:
    # The size is resolved; a hole 1e-9 from the outer ring asks for a size that is not, and
    # the message names where.
    ring = 1e6 + np.array([[0, 0], [1, 0], [1, 1], [0, 1]])
    hole = 1e6 + np.array([[0.5, 0.5], [0.5, 1 - 1e-9], [0.6, 1 - 1e-9], [0.6, 0.5]])
    with pytest.raises(LimitExceeded, match=r"near \(1000000.5, 1000001\)"):
        build_size_field(make_region([(ring, [hole])]), SizingParams(size=0.1))


def test_far_from_the_origin_a_resolved_size_still_meshes() -> None:
    # 84 steps of the coordinates per edge: valid, and no worse than a few percent.
    side = 1e-4
    ring = 1e9 + side * np.array([[0, 0], [1, 0], [1, 1], [0, 1]])
    mesh, _ = mesh_region(make_region([(ring, [])]), SizingParams(size=side / 10))
    quality = triangle_quality(mesh)
    assert quality.radius_ratio.min() > 0.8
