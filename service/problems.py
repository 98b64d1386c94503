"""RFC 9457 problem details: the one place where every error becomes ``application/problem+json``.

Routers raise :class:`Problem` (or let typed engine/input errors through); :func:`install` registers
the handlers that turn those, FastAPI's validation errors and Starlette's HTTP errors into problem
documents. Where an input is at fault the document carries a JSON ``pointer`` to it.

>>> json_pointer(("inputs", "boundary", "coordinates", 0, 17))
'/inputs/boundary/coordinates/0/17'
>>> json_pointer(("a/b", "m~n"))
'/a~1b/m~0n'
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping
from http import HTTPStatus
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.responses import JSONResponse

from engine import InvalidBoundary, InvalidMesh

from .formats import FormatError
from .geojson import BoundaryInputError, LocatedInvalidBoundary
from .jobs.admission import QueueFull
from .jobs.store import StoreCorrupt, StoreUnavailable
from .refusal import InputRefused

__all__ = [
    "MEDIA_TYPE",
    "OGC_EXCEPTIONS",
    "Problem",
    "ProblemResponse",
    "install",
    "json_pointer",
    "problem_for",
]

MEDIA_TYPE = "application/problem+json"
#: Exception types defined by OGC API - Processes, Part 1.
OGC_EXCEPTIONS = "http://www.opengis.net/def/exceptions/ogcapi-processes-1/1.0/"
#: Our own problem types (identifiers, not links).
EVOMESH = "urn:evomesh:problem:"

log = logging.getLogger("evomesh.service")


def json_pointer(path: Iterable[str | int]) -> str:
    """RFC 6901 pointer of a path of keys and indices."""
    return "".join("/" + str(p).replace("~", "~0").replace("/", "~1") for p in path)


class Problem(Exception):
    """An HTTP error with its problem document (RFC 9457).

    ``kind`` is a short name: an OGC exception (``no-such-job``), ``about:blank`` for plain HTTP
    errors, or one of ours (``invalid-input``, ``limit-exceeded``...).
    """

    def __init__(
        self,
        status: int,
        detail: str,
        *,
        kind: str = "about:blank",
        title: str | None = None,
        pointer: str | None = None,
        errors: list[dict[str, Any]] | None = None,
        headers: Mapping[str, str] | None = None,
        **extra: Any,
    ) -> None:
        super().__init__(detail)
        self.status = status
        self.detail = detail
        self.kind = kind
        self.title = title or HTTPStatus(status).phrase
        self.pointer = pointer
        self.errors = errors
        self.headers = dict(headers or {})
        self.extra = extra

    @property
    def type(self) -> str:
        if self.kind == "about:blank" or ":" in self.kind:
            return self.kind
        if self.kind in {"no-such-process", "no-such-job", "result-not-ready"}:
            return OGC_EXCEPTIONS + self.kind
        return EVOMESH + self.kind

    def document(self, instance: str | None = None) -> dict[str, Any]:
        doc: dict[str, Any] = {
            "type": self.type,
            "title": self.title,
            "status": self.status,
            "detail": self.detail,
        }
        if instance:
            doc["instance"] = instance
        if self.pointer is not None:
            doc["pointer"] = self.pointer
        if self.errors:
            doc["errors"] = self.errors
        doc.update(self.extra)
        return doc


class ProblemResponse(JSONResponse):
    """A JSON response with the problem media type."""

    media_type = MEDIA_TYPE


def _validation_errors(exc: RequestValidationError) -> list[dict[str, Any]]:
    out = []
    for err in exc.errors():
        loc = list(err.get("loc", ()))
        where = loc.pop(0) if loc else "body"
        item: dict[str, Any] = {"detail": str(err.get("msg", "invalid"))}
        if where == "body":
            item["pointer"] = json_pointer(loc)
        else:  # query, path, header, cookie
            item[str(where) if where != "query" else "parameter"] = ".".join(map(str, loc))
        out.append(item)
    return out


#: ``Retry-After`` of a 503 for a store that cannot be written, unless the settings say.
STORE_RETRY_AFTER = 10


def problem_for(exc: Exception, store_retry_after: int = STORE_RETRY_AFTER) -> Problem:
    """The problem an exception stands for (the one mapping of errors to HTTP)."""
    if isinstance(exc, Problem):
        return exc
    if isinstance(exc, StoreUnavailable):
        # Nothing was created or changed: the same request may succeed once space is back.
        return Problem(
            503,
            "the job store cannot be written now; nothing was changed, try again later",
            kind="store-unavailable",
            title="Store unavailable",
            headers={"Retry-After": str(store_retry_after)},
        )
    if isinstance(exc, StoreCorrupt):
        return Problem(500, "a stored item cannot be read", kind="store-corrupt")
    if isinstance(exc, RequestValidationError):
        errors = _validation_errors(exc)
        first = errors[0] if errors else {"detail": "invalid request"}
        where = first.get("pointer")
        detail = f"{first['detail']}" + (f" at {where}" if where else "")
        return Problem(
            422, detail, kind="invalid-input", title="Invalid input", pointer=where, errors=errors
        )
    if isinstance(exc, InputRefused):
        return Problem(422, exc.detail, kind=exc.kind, title=exc.title, pointer=exc.pointer)
    if isinstance(exc, LocatedInvalidBoundary):
        return _invalid_boundary(exc.cause, exc.pointer)
    if isinstance(exc, BoundaryInputError):
        return Problem(422, exc.message, kind="invalid-boundary", pointer=exc.pointer)
    if isinstance(exc, InvalidBoundary):  # a region the service put together: no pointer
        return _invalid_boundary(exc, None)
    if isinstance(exc, InvalidMesh):
        pointer = "/inputs/mesh"
        if exc.triangle is not None:
            pointer += f"/triangles/{exc.triangle}"
        elif exc.point is not None:
            pointer += f"/points/{exc.point}"
        return Problem(422, exc.message, kind="invalid-mesh", pointer=pointer)
    if isinstance(exc, FormatError):  # a request option at fault, or a writer that failed
        if exc.parameter:
            return Problem(400, exc.message, kind="invalid-parameter", parameter=exc.parameter)
        return Problem(500, exc.message, kind="format-error")
    if isinstance(exc, QueueFull):
        return Problem(
            429,
            str(exc),
            kind="queue-full",
            headers={"Retry-After": str(exc.retry_after)},
            waiting=exc.waiting,
            limit=exc.limit,
        )
    if isinstance(exc, StarletteHTTPException):
        return Problem(
            exc.status_code, str(exc.detail), headers=getattr(exc, "headers", None) or {}
        )
    return Problem(500, "the server failed to handle the request", kind="internal-error")


def _invalid_boundary(exc: InvalidBoundary, pointer: str | None) -> Problem:
    """The 422 of an engine's boundary error at ``pointer``, with the fault's coordinates."""
    problem = Problem(422, exc.message, kind="invalid-boundary", pointer=pointer)
    if exc.location is not None:
        problem.extra["location"] = list(exc.location)
    return problem


def response_for(problem: Problem, instance: str | None = None) -> ProblemResponse:
    return ProblemResponse(
        jsonable_encoder(problem.document(instance)),
        status_code=problem.status,
        headers=problem.headers,
    )


async def _handle(request: Request, exc: Exception) -> ProblemResponse:
    settings = getattr(request.app.state, "settings", None)
    problem = problem_for(exc, getattr(settings, "store_retry_after", STORE_RETRY_AFTER))
    if problem.status == 503:
        log.warning("%s %s: %s", request.method, request.url.path, exc)
    elif problem.status >= 500:
        log.error("unhandled error on %s %s", request.method, request.url.path, exc_info=exc)
    return response_for(problem, request.url.path)


async def _handle_unexpected(request: Request, exc: Exception) -> ProblemResponse:
    """An error nothing expected: a 500 problem that closes the connection. Starlette re-raises
    such an error after the response and the server then drops the connection; saying so
    (``Connection: close``) keeps a client from sending its next request on a dead connection
    (a keep-alive client had it reset)."""
    response = await _handle(request, exc)
    response.headers["Connection"] = "close"
    return response


def install(app: FastAPI) -> None:
    """Register the problem handlers on ``app``."""
    app.add_exception_handler(Exception, _handle_unexpected)
    for kind in (
        Problem,
        RequestValidationError,
        StarletteHTTPException,
        InputRefused,
        BoundaryInputError,
        InvalidBoundary,
        InvalidMesh,
        FormatError,
        QueueFull,
        StoreUnavailable,
        StoreCorrupt,
    ):
        app.add_exception_handler(kind, _handle)
