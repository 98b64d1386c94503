"""The workers' side of a job's result: how a document is stored, and the engine's stage
reports as a job's progress. The processes' computations are :mod:`service.processes`."""

from __future__ import annotations

import zlib
from collections.abc import Callable
from typing import Any

import orjson

from engine import SmoothingParams
from engine.pipeline import STAGE_WEIGHTS, job_progress

from .backend import ProgressCallback

__all__ = ["pack", "unpack"]


def pack(doc: dict[str, Any]) -> bytes:
    """A document as stored: compact JSON (orjson: a twentieth of ``json``'s time on float
    lists), zlib level 1 (a quarter of level 6's time for a result about 5% larger)."""
    return zlib.compress(orjson.dumps(doc), 1)


def unpack(data: bytes) -> bytes:
    """The JSON bytes of a stored document."""
    return zlib.decompress(data)


def _job_progress(
    progress: ProgressCallback, smoothing: SmoothingParams, first: str = "boundary"
) -> Callable[[str, float], None]:
    """The engine's stage reports as the job's progress: each stage's share of the bar is its
    measured cost (:func:`engine.pipeline.job_progress`), the message names it in words. A job
    that starts at stage ``first`` (``smooth``: at "swap") has the bar rescaled to start at 0."""
    weights = STAGE_WEIGHTS[smoothing.selection if smoothing.method == "ga" else "poor"]
    stages = list(weights)
    skipped = sum(weights[s] for s in stages[: stages.index(first)]) / sum(weights.values())
    low = int(99 * skipped)

    def report(percent: int, words: str) -> None:
        progress(round(99 * max(percent - low, 0) / (99 - low)), words)

    return job_progress(report if low else progress, smoothing)
