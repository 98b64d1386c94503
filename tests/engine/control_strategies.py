"""Hypothesis strategies of the mesh-control tests: valid random regions, points inside them."""

from __future__ import annotations

import shapely
from hypothesis import assume
from hypothesis import strategies as st

from engine import Region
from engine.errors import InvalidBoundary

from .regions import region_of, regions


@st.composite
def valid_regions(draw: st.DrawFn) -> tuple[Region, float]:
    """A random valid region and a size for it (degenerate stars are filtered out)."""
    rings, size = draw(regions())
    try:
        return region_of(rings), size
    except InvalidBoundary:  # the strategy can draw a degenerate star; nothing to mesh
        assume(False)
        raise  # unreachable: assume(False) raises


@st.composite
def inside(draw: st.DrawFn, region: Region) -> list[float]:
    """A point strictly inside ``region``."""
    x0, y0, x1, y1 = region.bounds
    p = [draw(st.floats(x0, x1)), draw(st.floats(y0, y1))]
    assume(region.to_shapely().contains(shapely.Point(p)))
    return p
