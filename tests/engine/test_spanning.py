"""Splitting wedge-spanning triangles: never worse, input corners kept whole (that the meshes
stay conforming is tested with every mesh_region in test_mesher_properties)."""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from engine.mesh import Mesh
from engine.quality import min_angle, radius_ratio
from engine.spanning import split_spanning


def _ladder(theta: float, rungs: int, ratio: float) -> Mesh:
    """A theta-degree wedge filled by a ladder of boundary-only triangles, rungs at distances
    1, ratio, ratio^2, ... from the corner."""
    t = np.radians(theta)
    r = ratio ** np.arange(rungs)
    lower = np.c_[r, np.zeros(rungs)]
    upper = np.c_[r * np.cos(t), r * np.sin(t)]
    pts = np.concatenate([[[0.0, 0.0]], lower, upper])
    low, up = 1 + np.arange(rungs), 1 + rungs + np.arange(rungs)
    tris = [[0, low[0], up[0]]]
    for k in range(rungs - 1):
        tris += [[low[k], low[k + 1], up[k]], [low[k + 1], up[k + 1], up[k]]]
    return Mesh(pts, np.array(tris, dtype=np.int64))


@settings(max_examples=40, deadline=None)
@given(theta=st.floats(20.0, 45.0), rungs=st.integers(3, 6), ratio=st.floats(1.3, 1.9))
def test_a_ladder_is_split_without_losing_its_corner(
    theta: float, rungs: int, ratio: float
) -> None:
    ladder = _ladder(theta, rungs, ratio)
    split = split_spanning(ladder, sides=False)
    before = radius_ratio(ladder.points, ladder.triangles)
    after = radius_ratio(split.points, split.triangles)
    smallest = min(float(min_angle(ladder.points, ladder.triangles).min()), 30.0)
    assert np.all(split.areas > 0)
    assert np.isclose(split.areas.sum(), ladder.areas.sum())
    # Only interior nodes are added; no angle falls below min(the smallest, 30) (3 degrees
    # below it before the node was placed under that bound), so the corner's triangle stays
    # whole where halving its angle would go below that.
    assert np.array_equal(split.points[: ladder.n_points], ladder.points)
    assert split.boundary_nodes[ladder.n_points :].sum() == 0
    assert min_angle(split.points, split.triangles).min() >= smallest - 1e-9
    if theta / 2 < smallest:
        assert [0, 1, 1 + rungs] in split.triangles.tolist()
    assert after.min() >= before.min()


def test_the_worst_rung_of_a_30_degree_ladder_is_lifted() -> None:
    # The rung's 105-degree foot caps it at 0.655; with a node it reaches the corner's 0.767.
    ladder = _ladder(30.0, 4, 1.67)
    split = split_spanning(ladder)
    assert radius_ratio(ladder.points, ladder.triangles).min() < 0.65
    assert split.n_points > ladder.n_points
    assert radius_ratio(split.points, split.triangles).min() > 0.65


def _uneven_corner(theta: float, far: float) -> tuple[Mesh, float]:
    """A theta-degree corner O whose first nodes sit at distances 1 (A1) and ``far`` (B) on its
    legs, closed by A2 on the first leg at 1.5 cos(theta): the quadrilateral O, B, A2, A1 cut
    into the corner's triangle O, B, A1 and B, A2, A1; and its smallest corner (degrees)."""
    u = np.array([np.cos(np.radians(theta)), np.sin(np.radians(theta))])
    pts = np.array([[0.0, 0.0], [far, 0.0], 1.5 * np.cos(np.radians(theta)) * u, u])
    corners = [theta, float(np.degrees(np.arctan2(pts[2, 1], far - pts[2, 0])))]
    corners.append(180.0 - theta - corners[1])
    return Mesh(pts, np.array([[0, 1, 3], [1, 2, 3]], dtype=np.int64)), min(corners)


@settings(max_examples=40, deadline=None)
@given(theta=st.floats(3.0, 30.0), stretch=st.floats(1.2, 1.6))
def test_an_uneven_corner_gets_a_node_on_its_boundary(theta: float, stretch: float) -> None:
    # Past 2 cos(theta) the far node's angle in the corner's triangle is below theta.
    corner, smallest = _uneven_corner(theta, stretch * 2.0 * np.cos(np.radians(theta)))
    split = split_spanning(corner)
    before = min_angle(corner.points, corner.triangles).min()
    after = min_angle(split.points, split.triangles).min()
    assert np.all(split.areas > 0)
    assert np.isclose(split.areas.sum(), corner.areas.sum())
    # The corner's triangle has a second angle below theta (the far node's); a node on a
    # boundary side lifts the smallest angle to the corners' bound or by 5% (one node cannot
    # always reach the bound), and every new node lies on the old boundary.
    assume(before < min(smallest, 30.0) - 0.5)
    assert after >= min(before * 1.05, min(smallest, 30.0) - 0.5)
    assert (
        radius_ratio(split.points, split.triangles).min()
        >= radius_ratio(corner.points, corner.triangles).min()
    )
    added = np.arange(corner.n_points, split.n_points)
    assert split.boundary_nodes[added].any()
    new = shapely.points(split.points[added[split.boundary_nodes[added]]])
    outline = shapely.Polygon(corner.points).boundary
    assert float(np.max(shapely.distance(new, outline))) < 1e-12
    assert np.array_equal(split.points[: corner.n_points], corner.points)
