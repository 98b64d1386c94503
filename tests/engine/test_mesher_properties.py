"""Property tests: every valid region gives a valid, conforming mesh."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings

from engine import SizingParams, mesh_region
from engine.errors import InvalidBoundary

from .regions import Rings, assert_conforming, region_of, regions


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(regions())
def test_random_regions_mesh_valid_and_conforming(case: tuple[Rings, float]) -> None:
    rings, size = case
    try:
        region = region_of(rings)
    except InvalidBoundary:  # the strategy can draw a degenerate star; nothing to mesh
        return
    mesh, _ = mesh_region(region, SizingParams(size=size))
    assert_conforming(mesh, region)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(regions())
def test_raw_front_without_relaxation_is_conforming(case: tuple[Rings, float]) -> None:
    rings, size = case
    try:
        region = region_of(rings)
    except InvalidBoundary:
        return
    mesh, _ = mesh_region(region, SizingParams(size=size), relax_sweeps=0)
    assert_conforming(mesh, region)


def test_multipolygon_parts_mesh_together() -> None:
    from engine import make_region

    region = make_region(
        [
            ([[0, 0], [1, 0], [1, 1], [0, 1]], []),
            ([[2, 0], [3, 0], [3, 1], [2, 1]], [[[2.4, 0.4], [2.6, 0.4], [2.5, 0.6]]]),
        ]
    )
    mesh, _ = mesh_region(region, SizingParams(size=0.1))
    assert_conforming(mesh, region)
    left = mesh.points[mesh.triangles].mean(axis=1)[:, 0] < 1.5
    np.testing.assert_allclose(mesh.areas[left].sum(), 1.0, rtol=1e-9)
