"""Typed errors raised by the engine.

The service turns these into problem+json in one place; the CLI prints their message on one line.
"""

from __future__ import annotations

__all__ = [
    "Cancelled",
    "EngineError",
    "InvalidBoundary",
    "InvalidMesh",
    "LimitExceeded",
    "MeshingError",
]


class EngineError(Exception):
    """Base class of every error the engine raises on purpose."""


class InvalidBoundary(EngineError, ValueError):
    """The region cannot be meshed as given.

    Attributes
    ----------
    part, ring, vertex:
        Where the problem is, as indices into the input: polygon ``part`` (0 for a single polygon),
        ``ring`` (0 = outer ring, 1.. = holes) and ``vertex`` within that ring (input numbering,
        before duplicates are dropped). Any of them is ``None`` when the problem has no such place.
    location:
        Coordinates of the problem (e.g. a self-intersection point), when there is one.
    """

    def __init__(
        self,
        message: str,
        *,
        part: int | None = None,
        ring: int | None = None,
        vertex: int | None = None,
        location: tuple[float, float] | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.part = part
        self.ring = ring
        self.vertex = vertex
        self.location = location


class InvalidMesh(EngineError, ValueError):
    """An input mesh is not a valid, counter-clockwise, manifold triangulation.

    ``triangle`` or ``point`` names the offending element (0-based) when there is one.
    """

    def __init__(
        self, message: str, *, triangle: int | None = None, point: int | None = None
    ) -> None:
        super().__init__(message)
        self.message = message
        self.triangle = triangle
        self.point = point


class MeshingError(EngineError, RuntimeError):
    """The mesher could not produce a valid mesh (a bug or an input beyond its limits)."""


class Cancelled(EngineError):
    """The caller's ``should_stop()`` returned true; the computation stopped early."""


class LimitExceeded(EngineError, ValueError):
    """The work asked for is over a limit (e.g. the mesh would have too many triangles)."""

    def __init__(self, message: str, *, limit: int, estimate: int) -> None:
        super().__init__(message)
        self.message = message
        self.limit = limit
        self.estimate = estimate
