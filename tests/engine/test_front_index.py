"""The front's spatial index: the trees for short edges find every edge a query box may meet,
and they give the mesh the uniform grid alone gives."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import Mesh, Region, SizingParams, make_region
from engine.discretize import discretize
from engine.front import advance_front, driver, index
from engine.front.constants import ALIVE, BUDGET, KEPT, NE, NEXT, NN, NS, VER, VERT
from engine.sizing import build_size_field

from .regions import assert_conforming


def _slit(width: float, depth: float = 0.6) -> Region:
    """The unit square with a slit ``width`` wide cut ``depth`` deep from the bottom."""
    a, b = 0.5 - width / 2, 0.5 + width / 2
    return make_region(
        [([[0, 0], [a, 0], [a, depth], [b, depth], [b, 0], [1, 0], [1, 1], [0, 1]], [])]
    )


def _spike(width: float) -> Region:
    """A square with a thin spike (``width`` wide at its base) reaching into a hole (the
    ring's orientation is make_region's to fix)."""
    hole = [
        [0.3, 0.3],
        [0.3, 0.7],
        [0.7, 0.7],
        [0.7, 0.5 + width / 2],
        [0.45, 0.5],
        [0.7, 0.5 - width / 2],
    ]
    return make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [hole])])


def _mesh(region: Region, size: float) -> Mesh:
    field = build_size_field(region, SizingParams(size=size))
    return advance_front(discretize(region, field), field)


GRADED = {
    "slit_1e-5": (_slit(1e-5), 0.05),
    "slit_3e-4": (_slit(3e-4, 0.3), 0.1),
    "spike_1e-3": (_spike(1e-3), 0.08),
}


@pytest.mark.parametrize("name", list(GRADED))
def test_trees_give_the_mesh_of_the_uniform_grid(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    region, size = GRADED[name]
    with_trees = _mesh(region, size)
    assert_conforming(with_trees, region)
    monkeypatch.setattr(index, "FINE_EDGE", 0.0)  # every edge in the grid: the index before trees
    grid_only = _mesh(region, size)
    np.testing.assert_array_equal(with_trees.points, grid_only.points)
    np.testing.assert_array_equal(with_trees.triangles, grid_only.triangles)


def _indexed(region: Region, size: float) -> tuple[driver.Front, driver.Index]:
    field = build_size_field(region, SizingParams(size=size))
    boundary = discretize(region, field)
    fr = driver._new_front(boundary, field, 1024)
    ix = driver._new_index(boundary.points, field, len(boundary.edges), len(fr.slots))
    hp = driver.Heap(
        key=np.empty(8 * len(boundary.edges) + 1024),
        ref=np.empty((8 * len(boundary.edges) + 1024, 2), dtype=np.int64),
    )
    assert driver._init(fr, ix, hp)
    return fr, ix


def test_the_index_drops_dead_entries_as_the_front_advances() -> None:
    # Deletion is lazy: kept until the arrays were full, the dead entries piled up in the
    # cells and trees where the front is fine, and every query there scanned them.
    region, _ = GRADED["slit_1e-5"]
    field = build_size_field(region, SizingParams(size=0.01))
    boundary = discretize(region, field)
    fr = driver._new_front(boundary, field, 1024)
    ix = driver._new_index(boundary.points, field, len(boundary.edges), len(fr.slots))
    hp = driver.Heap(key=np.empty(1 << 16), ref=np.empty((1 << 16, 2), dtype=np.int64))
    assert driver._init(fr, ix, hp)
    fr, ix, hp = driver._grown(fr, ix, hp, 15_000)
    assert driver._run(fr, ix, hp, field.as_tuple(), 15_000) == BUDGET  # mid-way
    ne, ns = int(fr.st[NE]), int(fr.st[NS])
    slot, ver = ix.ent[:ne, 0], ix.ent[:ne, 1]
    dead = ne - int(np.sum((fr.slots[slot, ALIVE] == 1) & (fr.slots[slot, VER] == ver)))
    assert dead <= (index.STALE - 1) * fr.st[KEPT] + ns // 8 + index.STALE_MIN


def test_short_edges_go_to_the_trees() -> None:
    fr, _ = _indexed(*GRADED["slit_1e-5"])
    assert fr.st[NN] > 0
    fr, _ = _indexed(make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])]), 0.05)
    assert fr.st[NN] == 0  # uniform: the grid alone, as before the trees


@settings(max_examples=60, deadline=None)
@given(
    width=st.floats(1e-6, 1e-2),
    # Boxes near the slit, down to far smaller than its edges, where the trees hold them.
    boxes=st.lists(
        st.tuples(
            st.floats(0.49, 0.51),
            st.floats(-0.01, 0.62),
            st.floats(1e-9, 0.02),
            st.floats(1e-9, 0.02),
        ),
        min_size=1,
        max_size=50,
    ),
)
def test_a_query_finds_every_edge_whose_box_meets_it(
    width: float, boxes: list[tuple[float, float, float, float]]
) -> None:
    fr, ix = _indexed(_slit(width), 0.05)
    ns = int(fr.st[NS])
    alive = np.flatnonzero(fr.slots[:ns, ALIVE] == 1)
    a = fr.pts[fr.slots[alive, VERT], :2]
    b = fr.pts[fr.slots[fr.slots[alive, NEXT], VERT], :2]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    for x0, y0, w, h in boxes:
        n = index.gather(fr, ix, x0, y0, x0 + w, y0 + h)
        hits = ix.hits[:n]
        assert len(set(hits.tolist())) == n  # each slot once
        meets = (lo[:, 0] <= x0 + w) & (hi[:, 0] >= x0) & (lo[:, 1] <= y0 + h) & (hi[:, 1] >= y0)
        assert set(alive[meets].tolist()) <= set(hits.tolist())


@pytest.mark.parametrize("width", [1e-6, 1e-5, 3e-4])
def test_a_point_query_at_an_edge_end_finds_the_edge(width: float) -> None:
    # An edge reaches outside the tree node that holds it (its centre is in the node): a
    # query at its far end must still find it.
    fr, ix = _indexed(_slit(width), 0.05)
    alive = np.flatnonzero(fr.slots[: int(fr.st[NS]), ALIVE] == 1)
    for s in alive:
        for v in (fr.slots[s, VERT], fr.slots[fr.slots[s, NEXT], VERT]):
            x, y = fr.pts[v, 0], fr.pts[v, 1]
            n = index.gather(fr, ix, x, y, x, y)
            assert s in ix.hits[:n]


def test_the_hot_front_kernels_run_without_reference_counting() -> None:
    # Counting every array taken out of the state tuples took half of the front's time.
    import importlib

    from engine.front.state import NO_REFCOUNT

    for module, names in NO_REFCOUNT.items():
        mod = importlib.import_module(f"engine.front.{module}")
        for name in names:
            assert getattr(mod, name).targetoptions.get("_nrt") is False, f"{module}.{name}"
    # And they still make a conforming mesh (same meshes as counted: benchmarks' fingerprints).
    square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    field = build_size_field(square, SizingParams(size=0.05))
    mesh = advance_front(discretize(square, field), field)
    assert_conforming(mesh, square)
    assert abs(mesh.areas.sum() - 1.0) < 1e-12
