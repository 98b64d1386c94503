"""What a picture shows: the colouring metrics, the options of a request, the colour scale.

>>> PictureOptions.from_query({"color": "min_angle"}).color
'min_angle'
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

import engine

__all__ = ["COLORMAP", "METRICS", "Metric", "PictureError", "PictureOptions", "color_range"]

FloatArray = NDArray[np.float64]

#: The colour map of pictures and of the web viewer (perceptually uniform, colour-blind safe).
COLORMAP = "viridis"


class PictureError(ValueError):
    """An option that is wrong, or that the document cannot satisfy; ``parameter`` names it."""

    def __init__(self, parameter: str, message: str) -> None:
        super().__init__(message)
        self.parameter = parameter
        self.message = message


@dataclass(frozen=True)
class Metric:
    """A figure that colours a mesh."""

    name: str  #: the ``color`` option value
    label: str  #: colour bar label
    on: Literal["cell", "point"]  #: per triangle or per node
    ideal: float  #: the best value (the good end of the colour scale)
    worst: float  #: the worst possible value
    step: float  #: the bad end of an automatic range is rounded to a multiple of this


def _metrics() -> dict[str, Metric]:
    """Triangle quality first (the default), node fitness next, then every other metric of
    the engine's registry: a metric registered there can colour a picture."""
    cells = [
        Metric(m.name, m.label, "cell", m.ideal, m.worst, 10.0 if m.unit == "deg" else 0.1)
        for m in engine.METRICS.values()
    ]
    fitness = Metric("fitness", "node fitness", "point", 1.0, 0.0, 0.1)
    return {m.name: m for m in (cells[0], fitness, *cells[1:])}


class _Metrics(Mapping[str, Metric]):
    """A live view of :func:`_metrics`, so a metric registered after import is offered too."""

    def __getitem__(self, name: str) -> Metric:
        return _metrics()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(_metrics())

    def __len__(self) -> int:
        return len(engine.METRICS) + 1


#: Metrics by ``color`` name: the document's ``cell_data`` fields and node fitness.
METRICS: Mapping[str, Metric] = _Metrics()


@dataclass(frozen=True)
class PictureOptions:
    """What a picture shows; :meth:`from_query` reads them from a request's query parameters."""

    color: str = "quality"  #: a key of :data:`METRICS`
    compare: bool = False  #: before and after side by side, with quality histograms
    width: int = 0  #: pixels; 0: 1200 (1600 when comparing)
    height: int = 0  #: pixels; 0: from the mesh's aspect ratio
    worst: int = 10  #: triangles outlined (the lowest quality)
    edges: bool | None = None  #: triangle edges; None: when they are large enough to see
    vmin: float | None = None  #: colour scale; None: from the data (see :func:`color_range`)
    vmax: float | None = None

    @classmethod
    def from_query(cls, query: Mapping[str, str]) -> PictureOptions:
        """Options from query parameters; :class:`PictureError` when one is wrong.

        >>> o = PictureOptions.from_query({"color": "fitness", "compare": "1", "width": "800"})
        >>> o.color, o.compare, o.width, o.height
        ('fitness', True, 800, 0)
        """
        color = query.get("color", cls.color)
        if color not in METRICS and color != "region":  # region: see service.render.regions
            choices = sorted([*METRICS, "region"])
            raise PictureError("color", f"unknown color {color!r}; choose one of {choices}")
        values: dict[str, Any] = {"color": color}
        for name in ("compare", "edges"):
            if name in query:
                values[name] = _flag(name, query[name])
        for name, lo, hi in (("width", 100, 8000), ("height", 100, 8000), ("worst", 0, 10_000)):
            if name in query:
                values[name] = _integer(name, query[name], lo, hi)
        for name in ("vmin", "vmax"):
            if name in query:
                values[name] = _number(name, query[name])
        if values.get("vmin", 0.0) == values.get("vmax", 1.0):
            raise PictureError("vmax", "vmin and vmax must differ")
        return cls(**values)


def _flag(name: str, text: str) -> bool:
    value = text.strip().lower()
    if value in ("1", "true", "yes", "on", ""):
        return True
    if value in ("0", "false", "no", "off"):
        return False
    raise PictureError(name, f"{name} must be 1 or 0, got {text!r}")


def _integer(name: str, text: str, lo: int, hi: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise PictureError(name, f"{name} must be an integer, got {text!r}") from None
    if not lo <= value <= hi:
        raise PictureError(name, f"{name} must be within [{lo}, {hi}], got {value}")
    return value


def _number(name: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise PictureError(name, f"{name} must be a finite number, got {text!r}")
    return value


def color_range(metric: Metric, values: list[FloatArray]) -> tuple[float, float]:
    """The colour scale: from the worst value seen (rounded outwards) to the ideal.

    Meshes worth looking at are mostly good, so a fixed scale would paint them one colour;
    starting at the worst value spends the colours where the triangles are.

    >>> color_range(METRICS["quality"], [np.array([0.47, 0.9, 1.0])])
    (0.4, 1.0)
    >>> color_range(METRICS["max_angle"], [np.array([61.0, 97.0])])
    (100.0, 60.0)
    """
    finite = [v[np.isfinite(v)] for v in values if v.size]
    seen = np.concatenate(finite) if finite else np.empty(0)
    if not seen.size:
        return metric.worst, metric.ideal
    up = metric.worst > metric.ideal  # the bad end is the high end
    extreme = float(seen.max() if up else seen.min())
    margin = metric.step / 4 * (1 if up else -1)  # the worst value is not at the very end
    rounding = math.ceil if up else math.floor
    rounded = rounding(round((extreme + margin) / metric.step, 6)) * metric.step
    lo, hi = sorted((metric.worst, metric.ideal))
    bad = min(max(rounded, lo), hi)
    if abs(bad - metric.ideal) < metric.step:  # a perfect mesh still gets a scale
        bad = metric.ideal + (metric.step if up else -metric.step)
    return round(bad, 6), metric.ideal
