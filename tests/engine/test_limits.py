"""Any size at any scale and place: a valid, conforming mesh, or an engine error saying why.

Sizes from 1e-12 of the region's to ten times it (the triangle limit), regions from 1e-6 to
1e6 across and up to 1e12 of their size from the origin (the coordinates' resolution), with or
without a refinement line: the engine answers each with a mesh or with a typed refusal
(``EngineError``), quickly, and never with another error (a 60 GiB allocation and a division
by zero were found this way; 800 examples under three seeds pass in about 8 s each).
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import EngineError, SizingParams, make_region, mesh_region
from engine.boundary import Region
from engine.mesh import Mesh, validate_mesh
from engine.refinement import Refinement

from .control_strategies import valid_regions

#: Few triangles, so a size the limit admits meshes quickly.
CAP = 20_000


def _moved(region: Region, scale: float, offset: float) -> Region:
    return make_region(
        [
            (
                (part.outer * scale + offset).tolist(),
                [(h * scale + offset).tolist() for h in part.holes],
            )
            for part in region.parts
        ]
    )


def _assert_covers(mesh: Mesh, region: Region) -> None:
    """Valid, every input vertex a node, and the region's area to within what rounding at the
    coordinates' resolution moves (each boundary edge by a few steps of its coordinates)."""
    validate_mesh(mesh.points, mesh.triangles)
    x0, y0, x1, y1 = region.bounds
    extent = max(x1 - x0, y1 - y0)
    step = float(np.spacing(np.abs(np.asarray(region.bounds)).max()))
    edges = len(mesh.boundary_edges)
    tol = 1e-9 * region.area + 16 * edges * step * extent
    assert abs(float(mesh.areas.sum()) - region.area) <= tol
    nodes = {tuple(p) for p in mesh.points.tolist()}
    assert all(tuple(v) in nodes for ring in region.rings for v in ring.tolist())


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    valid_regions(),
    st.sampled_from([1e-6, 1.0, 1e6]),
    st.sampled_from([0.0, 1e3, 1e6, 1e9, 1e12]),
    st.floats(-12.0, 1.0),
    st.booleans(),
)
def test_any_size_anywhere_meshes_or_is_refused(
    case: tuple[Region, float], scale: float, offset: float, exponent: float, refined: bool
) -> None:
    base, _ = case
    try:
        region = _moved(base, scale, offset * scale)
    except EngineError:  # rounding at that place merged vertices: a refusal, as it should be
        return
    x0, y0, x1, y1 = region.bounds
    size = max(x1 - x0, y1 - y0) * 10.0**exponent
    refinements = ()
    if refined:  # a line across the region at a tenth of the size
        line = {"type": "LineString", "coordinates": [[x0, y0], [x1, y1]]}
        refinements = (Refinement(line, size / 10),)
    try:
        mesh, _ = mesh_region(
            region, SizingParams(size=size, refinements=refinements), max_triangles=CAP
        )
    except EngineError:
        return
    assert mesh.n_triangles <= CAP
    _assert_covers(mesh, region)
