"""Typed errors of the geodata layer; the service turns each into a 422 problem."""

from __future__ import annotations

__all__ = ["GeoError", "InvalidCoordinates", "MissingDependency", "RegionTooLarge", "UnknownCRS"]


class GeoError(ValueError):
    """Base class of every error :mod:`service.geo` raises on purpose."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


class UnknownCRS(GeoError):
    """``crs`` is not a coordinate reference system pyproj knows; ``crs`` is the input."""

    def __init__(self, crs: object, reason: str = "") -> None:
        detail = f": {reason}" if reason else ""
        super().__init__(f"unknown coordinate reference system {crs!r}{detail}")
        self.crs = crs


class RegionTooLarge(GeoError):
    """A lon/lat region no single local projection keeps true (over a hemisphere, or a pole)."""


class InvalidCoordinates(GeoError):
    """A position is outside the CRS's range (e.g. latitude beyond 90 degrees).

    ``part``, ``ring`` and ``vertex`` index the input as :class:`engine.InvalidBoundary` does.
    """

    def __init__(self, message: str, *, part: int, ring: int, vertex: int) -> None:
        super().__init__(message)
        self.part = part
        self.ring = ring
        self.vertex = vertex


class MissingDependency(GeoError):
    """An optional package needed for this input is not installed."""
