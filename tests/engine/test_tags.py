"""Boundary tags and regions (engine.tags): every boundary edge carries its ring's tag or the
tag of the named run it lies on; every triangle knows its polygon."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import Mesh, Region, SizingParams, Tagging, TagRun, make_region, mesh_region, tag_mesh
from engine.tags import InvalidTag

from .control_strategies import valid_regions


def _mesh(parts: list[tuple[list[list[float]], list[list[list[float]]]]], size: float) -> Mesh:
    mesh, _ = mesh_region(make_region(parts), SizingParams(size))
    return mesh


def _circle(r: float, n: int, clockwise: bool = False) -> list[list[float]]:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False) * (-1 if clockwise else 1)
    return np.c_[r * np.cos(t), r * np.sin(t)].tolist()


def test_annulus_rings_get_outer_and_hole_tags() -> None:
    parts = [(_circle(1.0, 48), [_circle(0.3, 24)])]
    region = make_region(parts)
    mesh = _mesh(parts, 0.1)
    tagged = tag_mesh(mesh, region)
    assert tagged.tags == {"outer": 1, "hole-1": 2}
    assert len(tagged.lines) == len(mesh.boundary_edges)
    radius = np.hypot(*mesh.points[tagged.lines].mean(axis=1).T)
    assert np.all(radius[tagged.line_tag == 1] > 0.9)
    assert np.all(radius[tagged.line_tag == 2] < 0.31)
    assert set(tagged.region.tolist()) == {1}
    assert tagged.regions == {"region-0": 1}
    assert np.array_equal(tagged.fixed, mesh.boundary_nodes)


def test_a_run_tags_exactly_the_edges_along_it() -> None:
    square = [[0, 0], [2, 0], [2, 1], [0, 1]]
    region = make_region([(square, [])])
    mesh = _mesh([(square, [])], 0.1)
    # Input vertices 1 -> 3: the right side and the top.
    runs = (TagRun("inlet", [[2, 0], [2, 1], [0, 1]]),)
    tagged = tag_mesh(mesh, region, Tagging(names=["duct"], runs=runs))
    assert tagged.tags == {"duct/outer": 1, "inlet": 2}
    mid = mesh.points[tagged.lines].mean(axis=1)
    on_run = np.isclose(mid[:, 0], 2) | np.isclose(mid[:, 1], 1)
    assert np.array_equal(tagged.line_tag == 2, on_run)
    length = np.linalg.norm(np.diff(mesh.points[tagged.lines], axis=1)[:, 0], axis=1)
    assert np.isclose(length[tagged.line_tag == 2].sum(), 3.0)
    assert tagged.regions == {"duct": 1}


def test_each_part_is_a_region_with_its_own_tags() -> None:
    a = [[0, 0], [1, 0], [1, 1], [0, 1]]
    b = [[2, 0], [3, 0], [3, 1], [2, 1]]
    parts = [(a, []), (b, [])]
    mesh = _mesh(parts, 0.25)
    tagged = tag_mesh(mesh, make_region(parts), Tagging(names=[None, "right"]))
    assert tagged.regions == {"region-0": 1, "right": 2}
    assert tagged.tags == {"region-0/outer": 1, "right/outer": 2}
    x = mesh.points[mesh.triangles].mean(axis=1)[:, 0]
    assert np.array_equal(tagged.region, np.where(x > 1.5, 2, 1))
    xl = mesh.points[tagged.lines].mean(axis=1)[:, 0]
    assert np.array_equal(tagged.line_tag, np.where(xl > 1.5, 2, 1))


def test_a_run_off_the_boundary_is_a_located_error() -> None:
    square = [[0, 0], [1, 0], [1, 1], [0, 1]]
    runs = (TagRun("ok", [[0, 0], [1, 0]]), TagRun("nowhere", [[0.2, 0.5], [0.8, 0.5]]))
    with pytest.raises(InvalidTag, match="tag run 1 \\('nowhere'\\)") as err:
        tag_mesh(_mesh([(square, [])], 0.25), make_region([(square, [])]), Tagging(runs=runs))
    assert err.value.run == 1


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=valid_regions(), data=st.data())
def test_runs_of_random_rings_cover_exactly_their_length(
    case: tuple[Region, float], data: st.DataObject
) -> None:
    region, size = case
    ring = data.draw(st.sampled_from(region.rings))
    n = len(ring)
    start = data.draw(st.integers(0, n - 1))
    count = data.draw(st.integers(1, n - 1))
    path = ring[(start + np.arange(count + 1)) % n]
    mesh, _ = mesh_region(region, SizingParams(size))
    tagged = tag_mesh(mesh, region, Tagging(runs=(TagRun("run", path),)))
    length = np.linalg.norm(np.diff(mesh.points[tagged.lines], axis=1)[:, 0], axis=1)
    expected = np.linalg.norm(np.diff(path, axis=0), axis=1).sum()
    assert np.isclose(length[tagged.line_tag == tagged.tags["run"]].sum(), expected)
    perimeter = sum(np.linalg.norm(r - np.roll(r, -1, axis=0), axis=1).sum() for r in region.rings)
    assert np.isclose(length.sum(), perimeter)
    assert np.all(tagged.line_tag > 0)
    assert np.all(tagged.region > 0)
