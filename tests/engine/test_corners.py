"""Sharp input corners: the smallest angle reaches the bound the input sets."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import PipelineParams, SizingParams, make_region, mesh_then_smooth, triangle_quality

from .regions import assert_conforming


@settings(max_examples=25, deadline=None)
@given(
    theta=st.floats(3.0, 60.0),
    turn=st.floats(0.0, 2 * np.pi),
    side=st.floats(0.5, 2.0),
    size=st.floats(0.05, 0.3),
)
def test_a_wedge_reaches_its_corner_bound(
    theta: float, turn: float, side: float, size: float
) -> None:
    # A triangle with one theta-degree corner, turned and scaled at random: its other corners
    # are (180 - theta) / 2 >= 60 degrees, so the bound is min(theta, 30). Before the corner's
    # first boundary nodes were opened up, a 20-degree wedge got a 14.9-degree triangle.
    t = np.radians(theta)
    c, s = np.cos(turn), np.sin(turn)
    ring = np.array([[0.0, 0.0], [side, 0.0], [side * np.cos(t), side * np.sin(t)]])
    region = make_region([(ring @ np.array([[c, s], [-s, c]]), [])])
    params = PipelineParams(SizingParams(size=size * side))
    mesh = mesh_then_smooth(region, params, np.random.default_rng(0)).smoothed.mesh
    assert_conforming(mesh, region)
    assert triangle_quality(mesh).min_angle.min() >= min(theta, 30.0) - 0.5
