"""Test regions built without hypothesis, so that the benchmarks can draw them too."""

from __future__ import annotations

import numpy as np


def spike_ring(theta: float, legs: tuple[float, float], size: float) -> list[list[float]]:
    """A ``theta``-degree spike at the origin whose legs, ``legs`` times ``size`` long, turn
    away at input vertices into a body reaching x = 1 (y from -0.5 to 0.5)."""
    half = np.radians(theta) / 2
    a = legs[0] * size * np.array([np.cos(half), np.sin(half)])
    b = legs[1] * size * np.array([np.cos(half), -np.sin(half)])
    ring = [[0.0, 0.0], b, [b[0], -0.5], [1.0, -0.5], [1.0, 0.5], [a[0], 0.5], a]
    return np.asarray(ring, dtype=float).tolist()
