"""Hypothesis strategies for random regions, and the conformity check every mesh must pass."""

from __future__ import annotations

import numpy as np
import shapely
from hypothesis import strategies as st
from shapely.geometry import Polygon, box

from engine import Mesh, Region, make_region, validate_mesh
from engine.mesh import edge_table

from .shapes import spike_ring as spike_ring  # re-exported: the tests draw spikes here

Rings = tuple[list[list[float]], list[list[list[float]]]]


@st.composite
def star_polygons(draw: st.DrawFn) -> list[list[float]]:
    """Star-shaped (possibly very non-convex) polygons around the origin."""
    n = draw(st.integers(3, 30))
    angles = np.sort(draw(st.lists(st.floats(0, 2 * np.pi), min_size=n, max_size=n, unique=True)))
    radii = draw(st.lists(st.floats(0.2, 1.0), min_size=n, max_size=n))
    pts = np.c_[np.cos(angles) * radii, np.sin(angles) * radii]
    return pts.tolist()


@st.composite
def polyomino_regions(draw: st.DrawFn) -> Polygon:
    """Outlines of random connected sets of grid cells: non-convex, not star-shaped, with holes."""
    size = draw(st.integers(2, 6))
    cells = {(0, 0)}
    steps = draw(
        st.lists(st.tuples(st.integers(-1, 1), st.integers(-1, 1)), min_size=3, max_size=30)
    )
    x, y = 0, 0
    for dx, dy in steps:
        if dx and dy:
            dy = 0
        x, y = max(min(x + dx, size), -size), max(min(y + dy, size), -size)
        cells.add((x, y))
    shape = shapely.unary_union([box(i, j, i + 1, j + 1) for i, j in cells])
    if shape.geom_type != "Polygon":  # cells touching only at corners
        shape = max(shapely.get_parts(shape), key=lambda g: g.area)
    return shapely.set_precision(shape, 1e-9).normalize()


def _holes_inside(draw: st.DrawFn, shell: Polygon, scale: float) -> list[list[list[float]]]:
    holes: list[Polygon] = []
    inner = shell.buffer(-0.05 * scale)
    for _ in range(draw(st.integers(0, 3))):
        if inner.is_empty:
            break
        x0, y0, x1, y1 = inner.bounds
        cx = draw(st.floats(x0, x1))
        cy = draw(st.floats(y0, y1))
        r = draw(st.floats(0.03, 0.25)) * scale
        k = draw(st.integers(3, 10))
        phase = draw(st.floats(0, 2 * np.pi))
        a = phase + 2 * np.pi * np.arange(k) / k
        hole = Polygon(np.c_[cx + r * np.cos(a), cy + r * np.sin(a)])
        gap = 0.02 * scale
        if inner.contains(hole) and all(hole.distance(h) > gap for h in holes):
            holes.append(hole)
    return [np.asarray(h.exterior.coords).tolist() for h in holes]


@st.composite
def regions(draw: st.DrawFn) -> tuple[Rings, float]:
    """A random region (outer ring and holes) and a target size giving at most a few thousand
    triangles."""
    if draw(st.booleans()):
        outer = draw(star_polygons())
        shell = Polygon(outer)
        # Features finer than 1/1000 of the extent (a spike 1e-5 wide) are meshed correctly but
        # slowly by the uniform search grid (see README, Meshing): they have their own
        # regression tests, and would make this test's run time a lottery.
        with np.errstate(divide="ignore", invalid="ignore"):  # GEOS on degenerate stars
            clearance = shapely.minimum_clearance(shell)
        if not shell.is_valid or shell.area < 1e-3 or not clearance >= 1e-3:
            outer = [[0, 0], [1, 0], [0.5, 0.8]]
            shell = Polygon(outer)
    else:
        shell = draw(polyomino_regions())
        outer = np.asarray(shell.exterior.coords).tolist()
    x0, y0, x1, y1 = shell.bounds
    scale = max(x1 - x0, y1 - y0)
    holes = _holes_inside(draw, shell, scale)
    if shell.geom_type == "Polygon" and shell.interiors:
        holes += [np.asarray(r.coords).tolist() for r in shell.interiors]
    area = Polygon(outer, holes).area
    n_target = draw(st.integers(20, 3000))
    size = float(np.sqrt(area / (0.433 * n_target)))
    return (outer, holes), size


def assert_conforming(mesh: Mesh, region: Region) -> None:
    """The mesh is valid and covers exactly the region, keeping every input vertex."""
    validate_mesh(mesh.points, mesh.triangles)
    assert np.all(mesh.areas > 0)
    np.testing.assert_allclose(mesh.areas.sum(), region.area, rtol=1e-9)
    _, count, _ = edge_table(mesh.triangles)
    assert set(np.unique(count).tolist()) <= {1, 2}
    # Boundary edges lie on the region's boundary and add up to its perimeter.
    shape = region.to_shapely()
    bnd = mesh.boundary_edges
    a, b = mesh.points[bnd[:, 0]], mesh.points[bnd[:, 1]]
    scale = max(np.ptp(mesh.points, axis=0))
    mids = shapely.points(0.5 * (a + b))
    assert float(np.max(shapely.distance(mids, shape.boundary))) < 1e-9 * scale
    np.testing.assert_allclose(np.hypot(*(b - a).T).sum(), shape.length, rtol=1e-9)
    # Every input vertex is a mesh vertex.
    have = {tuple(p) for p in mesh.points.tolist()}
    for ring in region.rings:
        for p in ring.tolist():
            assert tuple(p) in have


def region_of(rings: Rings) -> Region:
    outer, holes = rings
    return make_region([(outer, holes)])


#: A spike's corner (degrees), its legs (in sizes; unequal, so the corner's first nodes sit at
#: unequal distances on them) and the size.
SPIKES = st.tuples(
    st.floats(5.0, 45.0), st.tuples(st.floats(0.3, 2.5), st.floats(0.3, 2.5)), st.floats(0.1, 0.2)
)
