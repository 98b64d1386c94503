"""A metric the registry does not ship, registered for the length of a test."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

import engine
from engine.quality import FloatArray, Metric, TriangleGeometry, register_metric


def _edge_ratio(g: TriangleGeometry) -> FloatArray:
    sides = np.sqrt(np.stack(g.squared_sides))
    ratio: FloatArray = sides.max(axis=0) / sides.min(axis=0)
    return ratio


@contextmanager
def edge_ratio() -> Iterator[Metric]:
    """``edge_ratio`` (longest over shortest side) in :data:`engine.METRICS` while inside."""
    metric = register_metric(Metric("edge_ratio", _edge_ratio, "longest / shortest side", 1, 10))
    try:
        yield metric
    finally:
        del engine.METRICS["edge_ratio"]
