"""Digitised boundaries: resampling to the local size keeps corners and stays within tolerance."""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import PipelineParams, SizingParams, SmoothingParams, make_region, mesh_then_smooth
from engine.boundary import Region
from engine.resample import resample_region

NO_SMOOTHING = SmoothingParams(method="none")


def _ellipse(n: int = 20_000, a: float = 1000.0, b: float = 600.0) -> Region:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return make_region([(np.c_[a * np.cos(t), b * np.sin(t)], [])])


def _noisy_rectangle(width: float, height: float, step: float, noise: float) -> Region:
    """A rectangle traced every ``step`` with ``noise`` of jitter, corners digitised exactly."""
    rng = np.random.default_rng(7)
    corners = np.array([[0, 0], [width, 0], [width, height], [0, height]], dtype=float)
    pts = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        n = int(np.hypot(*(b - a)) / step)
        t = np.arange(n) / n
        side = a + t[:, None] * (b - a)
        side[1:] += rng.uniform(-noise, noise, size=(n - 1, 2))
        pts.append(side)
    return make_region([(np.concatenate(pts), [])])


def _deviation(before: Region, after: Region) -> float:
    lines = shapely.boundary(after.to_shapely())
    return float(max(shapely.distance(shapely.points(r), lines).max() for r in before.rings))


def test_dense_ellipse_meshes_to_the_area_count_within_tolerance() -> None:
    region = _ellipse()
    sizing = SizingParams(100.0, resample=True)
    result = mesh_then_smooth(region, PipelineParams(sizing, smoothing=NO_SMOOTHING))
    area_count = region.area / (np.sqrt(3) / 4 * 100.0**2)
    triangles = result.smoothed.mesh.n_triangles
    assert abs(triangles - area_count) <= 0.3 * area_count, (triangles, area_count)
    boundary = result.smoothed.summary["boundary"]
    assert boundary["vertices_before"] == 20_000
    assert 0 < boundary["max_deviation"] <= boundary["tolerance"] <= 10.0
    # The meshed boundary itself (not only the resampled ring) is within the tolerance.
    mesh = result.smoothed.mesh
    edges = mesh.points[mesh.boundary_edges]
    meshed = shapely.multilinestrings(list(edges))
    far = shapely.distance(shapely.points(region.rings[0]), meshed).max()
    assert far <= boundary["tolerance"] + 1e-9


def test_without_resample_every_vertex_stays() -> None:
    region = _ellipse(2000, 100.0, 60.0)
    out = resample_region(region, SizingParams(10.0, resample=True))
    assert out.region.n_vertices < 200
    sizing = SizingParams(10.0)
    result = mesh_then_smooth(region, PipelineParams(sizing, smoothing=NO_SMOOTHING))
    assert result.smoothed.mesh.n_points > 2000
    assert "boundary" not in result.smoothed.summary


def test_noisy_rectangle_keeps_its_corners() -> None:
    region = _noisy_rectangle(1000.0, 600.0, 0.3, 0.05)
    sizing = SizingParams(100.0, resample=True)
    result = mesh_then_smooth(region, PipelineParams(sizing, smoothing=NO_SMOOTHING))
    points = result.smoothed.mesh.points
    for corner in ([0, 0], [1000, 0], [1000, 600], [0, 600]):
        assert np.hypot(*(points - corner).T).min() < 1e-9, corner
    assert result.smoothed.mesh.n_points < 200


def test_explicit_tolerance_is_kept() -> None:
    region = _ellipse(4000, 100.0, 60.0)
    loose = resample_region(region, SizingParams(10.0, resample=True))
    tight = resample_region(region, SizingParams(10.0, resample=True, resample_tolerance=0.01))
    assert tight.max_deviation <= 0.01 < loose.max_deviation
    assert tight.region.n_vertices > loose.region.n_vertices


@st.composite
def _wobbly(draw: st.DrawFn) -> tuple[Region, float]:
    """A star-shaped ring with a few harmonics and digitising noise, and a size."""
    n = draw(st.integers(200, 3000))
    k = draw(st.lists(st.floats(-0.15, 0.15), min_size=1, max_size=6))
    noise = draw(st.floats(0.0, 0.1)) * 2.0 * np.pi * 0.1 / n  # below the spacing
    seed = draw(st.integers(0, 2**16))
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    r = 1.0 + sum(a * np.sin((i + 2) * t + i) for i, a in enumerate(k))
    ring = np.c_[r * np.cos(t), r * np.sin(t)]
    ring += np.random.default_rng(seed).uniform(-noise, noise, ring.shape)
    return make_region([(ring, [])]), draw(st.floats(0.02, 0.5))


@settings(max_examples=40, deadline=None)
@given(_wobbly())
def test_resampled_rings_stay_valid_and_within_tolerance(case: tuple[Region, float]) -> None:
    region, size = case
    out = resample_region(region, SizingParams(size, resample=True))
    assert out.region.to_shapely().is_valid
    assert out.region.n_vertices <= region.n_vertices
    tolerance = 0.1 * size
    assert out.max_deviation <= tolerance + 1e-12
    assert _deviation(region, out.region) <= tolerance + 1e-12
    assert abs(out.max_deviation - _deviation(region, out.region)) <= 1e-9


def test_digitised_constraint_lines_are_resampled_with_the_rings() -> None:
    """A noisy rectangle with a digitised constraint line from a ring vertex into the region:
    the line keeps its ends and corner, stays within the tolerance and is split at the size."""
    from engine import mesh_with_constraints
    from engine.mesh import edge_table

    region = _noisy_rectangle(100.0, 60.0, 0.3, 0.05)
    start = region.rings[0][len(region.rings[0]) // 8]  # a vertex of the southern side
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 400)
    leg1 = np.c_[start[0] + 0 * t, start[1] + 30 * t]  # north, then east: a corner at the turn
    leg2 = np.c_[start[0] + 40 * t[1:], start[1] + 30 + 0 * t[1:]]
    path = np.concatenate([leg1, leg2])
    path[1:-1] += rng.uniform(-0.05, 0.05, (len(path) - 2, 2))
    path[len(leg1) - 1] = [start[0], start[1] + 30]  # the corner exactly
    line = {"type": "LineString", "coordinates": path.tolist()}
    params = PipelineParams(SizingParams(10.0, resample=True), smoothing=SmoothingParams("none"))
    out = mesh_with_constraints(region, params, [line])
    mesh = out.result.smoothed.mesh
    boundary = out.result.smoothed.summary["boundary"]
    assert boundary["max_deviation"] <= boundary["tolerance"] <= 1.0
    assert 0 < boundary["constraints_max_deviation"] <= boundary["tolerance"]
    for p in (start, path[len(leg1) - 1], path[-1]):  # ends and corner are mesh nodes
        assert np.hypot(*(mesh.points - p).T).min() < 1e-9
    assert 7 <= len(out.edges) <= 12  # 70 long at size 10, not 800 digitised pieces
    have = {tuple(e) for e in edge_table(mesh.triangles)[0].tolist()}
    assert all(tuple(sorted(e)) in have for e in out.edges.tolist())
    assert mesh.n_triangles < 300
    assert out.region is not None
    assert out.region.n_vertices < 20
