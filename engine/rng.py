"""Counter-based random numbers for numba kernels: a stream per (seed, sweep, node).

A node's draws depend only on the base seed, the sweep, the node id and the draw's position in
the stream, never on which thread runs the node or in which order nodes run; that is what makes
the GA's output identical on any thread count. The mixing function is splitmix64 (Steele, Lea &
Flood 2014), which passes BigCrush when fed a counter.

>>> import numpy as np
>>> key = stream_key(np.uint64(42), 1, 7)
>>> u, v = uniform_pair(key, np.uint64(0))
>>> 0.0 <= u < 1.0 and 0.0 <= v < 1.0, (u, v) == uniform_pair(key, np.uint64(0)), u == v
(True, True, False)
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["base_seed", "mix64", "stream_key", "stream_keys", "uniform_pair"]

# numba types uint64 (op) int64 as float64, so every constant below is an explicit uint64.
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S32 = np.uint64(32)
_LOW32 = np.uint64(0xFFFFFFFF)
_TO_UNIT = 1.0 / 4294967296.0  # 2**-32


@numba.njit(cache=True, inline="always")
def mix64(z: np.uint64) -> np.uint64:
    """The splitmix64 finaliser: a bijective, well-mixing hash of 64 bits."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@numba.njit(cache=True)
def stream_key(base: np.uint64, sweep: int, node: int) -> np.uint64:
    """The key of one node's stream in one sweep."""
    k = mix64(base + _GOLDEN)
    k = mix64(k ^ (np.uint64(sweep) * _GOLDEN))
    return mix64(k ^ (np.uint64(node) * _M1 + _GOLDEN))


@numba.njit(cache=True)
def stream_keys(base: np.uint64, sweep: int, nodes: NDArray[np.int64]) -> NDArray[np.uint64]:
    """:func:`stream_key` of each node of ``nodes``."""
    out = np.empty(len(nodes), dtype=np.uint64)
    for i in range(len(nodes)):
        out[i] = stream_key(base, sweep, nodes[i])
    return out


@numba.njit(cache=True, inline="always")
def uniform_pair(key: np.uint64, counter: np.uint64) -> tuple[float, float]:
    """Pair number ``counter`` of stream ``key``: two doubles uniform on [0, 1), 32 random bits
    each (the two halves of one hash: one 64-bit mix per two draws)."""
    z = mix64(key + (counter + np.uint64(1)) * _GOLDEN)
    return float(z >> _S32) * _TO_UNIT, float(z & _LOW32) * _TO_UNIT


def base_seed(rng: np.random.Generator) -> np.uint64:
    """Draw the one 64-bit base seed a smoothing run derives all its streams from.

    >>> bool(base_seed(np.random.default_rng(0)) == base_seed(np.random.default_rng(0)))
    True
    """
    return np.uint64(rng.integers(0, np.iinfo(np.uint64).max, dtype=np.uint64, endpoint=True))
