"""Request bodies: the size limit, enforced while the body streams in, and the JSON reading of
bodies (media type, nesting depth before decoding, decoding off the event loop: in a thread, or
for large bodies in a small process pool, since orjson and pydantic hold the GIL), and the trusted
Host check answering with a problem document."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable, Coroutine, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from functools import cache
from typing import Any, Generic, TypeVar, cast

import anyio.to_thread
import numpy as np
import orjson
from fastapi import Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.routing import APIRoute
from pydantic import TypeAdapter, ValidationError
from starlette.exceptions import HTTPException
from starlette.middleware.trustedhost import TrustedHostMiddleware
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from .problems import Problem, problem_for, response_for

log = logging.getLogger("evomesh.service")

__all__ = [
    "BodyLimit",
    "JsonBodyRoute",
    "Then",
    "TrustedHosts",
    "body_pool",
    "decode_json",
    "json_depth",
    "problem_fields",
    "read_json_body",
]


class BodyTooLarge(HTTPException):
    """Raised from ``receive`` past the limit; FastAPI lets HTTP exceptions through."""

    def __init__(self, limit: int) -> None:
        super().__init__(413, f"the request body is over the limit of {limit} bytes")


class BodyLimit:
    """Refuse bodies over ``max_bytes`` with 413: at once when ``Content-Length`` says so, and
    otherwise as soon as the streamed chunks pass the limit, without reading the rest."""

    def __init__(self, app: ASGIApp, max_bytes: int) -> None:
        self.app = app
        self.max_bytes = max_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        for name, value in scope.get("headers", ()):
            if name == b"content-length":
                try:
                    declared = int(value)
                except ValueError:
                    declared = -1
                if declared > self.max_bytes:
                    problem = Problem(413, BodyTooLarge(self.max_bytes).detail)
                    response = response_for(problem, scope.get("path"))
                    response.headers["Connection"] = "close"
                    await response(scope, receive, send)
                    return
        received = 0

        async def limited() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.max_bytes:
                    raise BodyTooLarge(self.max_bytes)
            return message

        await self.app(scope, limited, send)


#: Bodies up to this size are decoded on the event loop (a thread hop costs more than that).
INLINE_BODY_BYTES = 64 * 1024


def json_depth(body: bytes) -> int:
    """The deepest nesting of arrays and objects in a JSON text, found without decoding it.

    Vectorised (a 30 MB body takes tens of milliseconds), and bracket characters inside strings,
    escaped quotes included, do not count. The text need not be valid JSON.

    >>> json_depth(b'{"a": [[1, 2], {"b": "]]]]\\\\"[[["}]}')
    3
    >>> json_depth(b"17")
    0
    """
    a = np.frombuffer(body, dtype=np.uint8)
    quotes = np.flatnonzero(a == ord('"'))
    slashes = np.flatnonzero(a == ord("\\"))
    if quotes.size and slashes.size:
        # A quote ends a string unless an odd run of backslashes precedes it.
        breaks = np.flatnonzero(np.diff(slashes) != 1)
        starts = slashes[np.r_[0, breaks + 1]]
        ends = slashes[np.r_[breaks, slashes.size - 1]]
        k = np.minimum(np.searchsorted(ends, quotes - 1), ends.size - 1)
        run = np.where(ends[k] == quotes - 1, ends[k] - starts[k] + 1, 0)
        quotes = quotes[run % 2 == 0]
    # "[" and "{" are 0x5B and 0x7B, "]" and "}" 0x5D and 0x7D: one mask finds all four.
    pos = np.flatnonzero((a | 0x20) == 0x7B)
    pos = np.concatenate([pos, np.flatnonzero((a | 0x20) == 0x7D)])
    if not pos.size:
        return 0
    pos.sort()
    step = np.where((a[pos] | 0x20) == 0x7B, 1, -1)
    step[np.searchsorted(quotes, pos) % 2 == 1] = 0  # inside a string
    return int(np.cumsum(step).max(initial=0))


def decode_json(body: bytes, max_depth: int) -> Any:
    """A request body's JSON value; :class:`Problem` for one nested too deep (checked first, so
    no decoder or later walk can recurse on it) or one that is not JSON (with line and column)."""
    depth = json_depth(body)
    if depth > max_depth:
        raise Problem(
            422,
            f"the body is nested {depth} levels deep, over the limit of {max_depth}",
            kind="limit-exceeded",
            title="Input over a limit",
            limit=max_depth,
        )
    try:
        return orjson.loads(body)
    except orjson.JSONDecodeError as exc:
        reason = exc.msg.split(": line ", 1)[0]
        raise Problem(
            400,
            f"the body is not JSON: {reason} at line {exc.lineno}, column {exc.colno}",
            kind="invalid-json",
            title="Malformed JSON",
            line=exc.lineno,
            column=exc.colno,
        ) from None


def _is_json(content_type: str) -> bool:
    media = content_type.split(";", 1)[0].strip().lower()
    return media == "application/json" or (
        media.startswith("application/") and media.endswith("+json")
    )


def _decode_and_validate(body: bytes, max_depth: int, field: Any) -> Any:
    value = decode_json(body, max_depth)
    if field is None:
        return value
    model, errors = field.validate(value, loc=("body",))
    if errors:
        raise RequestValidationError(errors, body=value)
    return model


@cache
def _adapter(annotation: Any) -> TypeAdapter[Any]:
    return TypeAdapter(annotation)


#: A step run on a large body's validated value in the pool process, after validation:
#: ``then(value) -> (value FastAPI gets, what the handler finds in request.state.prepared)``;
#: it must pickle (a module-level function or a partial of one).
Then = Callable[[Any], tuple[Any, Any]]


def problem_fields(exc: Problem) -> tuple[int, str, dict[str, Any]]:
    """A problem as a tuple that pickles (:class:`Problem` does not survive pickling)."""
    fields = {
        "kind": exc.kind,
        "title": exc.title,
        "pointer": exc.pointer,
        "errors": exc.errors,
        "headers": exc.headers,
        **exc.extra,
    }
    return exc.status, exc.detail, fields


T = TypeVar("T")


@dataclass(frozen=True)
class PoolAdmission(Generic[T]):
    """What a :data:`Then` step admitted in the body pool: its value, or the problem that
    refuses the request (as :func:`problem_fields`' tuple, which pickles)."""

    value: T | None = None
    problem: tuple[int, str, dict[str, Any]] | None = None

    @classmethod
    def of(cls, admit: Callable[[], T]) -> PoolAdmission[T]:
        """``admit()``'s value, or the problem its error is answered with; an error answered
        with a 5xx is a bug and raised, as it would be in place."""
        try:
            return cls(admit())
        except Exception as exc:
            problem = problem_for(exc)
            if problem.status >= 500:
                raise
            return cls(problem=problem_fields(problem))

    def result(self) -> T:
        """The value, or the problem raised (where admitting in place would raise it)."""
        if self.problem is not None:
            status, detail, fields = self.problem
            raise Problem(status, detail, **fields)
        return cast(T, self.value)


def _validate_in_child(
    body: bytes, max_depth: int, annotation: Any, then: Then | None = None
) -> tuple[str, Any]:
    """What a pool process answers: ``("ok", value)`` (``then``'s pair when given),
    ``("problem", fields)`` or ``("invalid", errors)``; tagged tuples because :class:`Problem`
    does not survive pickling."""
    try:
        value = decode_json(body, max_depth)
    except Problem as exc:
        return "problem", problem_fields(exc)
    if annotation is not None:
        try:
            # as FastAPI's ModelField.validate does it, so the answers are the same
            value = _adapter(annotation).validate_python(value, from_attributes=True)
        except ValidationError as exc:
            errors = [{**e, "loc": ("body", *e["loc"])} for e in exc.errors(include_url=False)]
            return "invalid", errors
    return "ok", value if then is None else then(value)


def body_pool(workers: int) -> ProcessPoolExecutor | None:
    """The processes that decode and validate large bodies (``None`` when ``workers`` is 0).
    Spawned, not forked: the service runs threads (and numba) that a fork would copy mid-step.
    They start with the first large body (their imports take a second, off the loop), so a
    service that is never sent one never pays for them."""
    if workers <= 0:
        return None
    import multiprocessing

    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))


def _poolable(field: Any) -> Any:
    """The body's type when a pool process can import it by name, else ``False``."""
    if field is None:
        return None
    annotation = getattr(getattr(field, "field_info", None), "annotation", None)
    qualname = getattr(annotation, "__qualname__", "<locals>")
    return False if annotation is None or "<locals>" in qualname else annotation


async def _in_pool(
    pool: ProcessPoolExecutor,
    body: bytes,
    max_depth: int,
    annotation: Any,
    field: Any,
    then: Then | None = None,
) -> Any:
    try:
        # awaited on the loop: no thread waits for the child
        tag, payload = await asyncio.wrap_future(
            pool.submit(_validate_in_child, body, max_depth, annotation, then)
        )
    except BrokenProcessPool:  # a child died (out of memory): this body in a thread, as before
        log.error("the body process pool is broken; reading bodies in a thread")
        value = await anyio.to_thread.run_sync(_decode_and_validate, body, max_depth, field)
        return value if then is None else (value, None)
    if tag == "problem":
        status, detail, fields = payload
        raise Problem(status, detail, **fields)
    if tag == "invalid":
        raise RequestValidationError(payload, body=None)
    return payload


async def read_json_body(
    request: Request,
    max_depth: int,
    field: Any = None,
    pool: ProcessPoolExecutor | None = None,
    pool_bytes: int = 0,
    then: Then | None = None,
) -> None:
    """Check, decode and validate (against ``field``, a route's body field) a JSON request body
    before FastAPI sees it: 415 for another media type; a large body is decoded and validated
    in a thread, off the event loop, and one of ``pool_bytes`` or more in ``pool`` (the GIL
    that orjson and pydantic hold would stall the loop's other requests), followed there by
    ``then`` (whose second value is left in ``request.state.prepared``). The result is left
    where ``request.json()`` finds it; FastAPI's own validation of a model instance then takes
    no time."""
    body = await request.body()
    if not body:
        return
    content_type = request.headers.get("content-type", "")
    if not _is_json(content_type):
        raise Problem(
            415,
            f"the body must be JSON (Content-Type: application/json), not "
            f"{content_type or 'a body without a Content-Type'}",
            kind="unsupported-media-type",
            headers={"Accept-Post": "application/json"},
        )
    annotation = _poolable(field)
    if len(body) <= INLINE_BODY_BYTES:
        value = _decode_and_validate(body, max_depth, field)
    elif pool is not None and len(body) >= pool_bytes and annotation is not False:
        value = await _in_pool(pool, body, max_depth, annotation, field, then)
        if then is not None:
            value, request.state.prepared = value
    else:
        value = await anyio.to_thread.run_sync(_decode_and_validate, body, max_depth, field)
    request._json = value  # what Request.json() returns from now on


class JsonBodyRoute(APIRoute):
    """A route whose JSON body is read by :func:`read_json_body` (depth limit, media type,
    decoding off the loop, syntax errors with line and column)."""

    def pool_step(self, request: Request) -> Then | None:
        """What a pool process does with this route's large body after validating it (see
        :func:`read_json_body`); none by default."""
        del request
        return None

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()
        if self.body_field is None:
            return handler

        async def read_then_handle(request: Request) -> Response:
            settings = request.app.state.settings
            await read_json_body(
                request,
                settings.max_json_depth,
                self.body_field,
                getattr(request.app.state, "body_pool", None),
                settings.body_pool_bytes,
                self.pool_step(request),
            )
            return await handler(request)

        return read_then_handle


class TrustedHosts:
    """Starlette's trusted-host check, its refusal a problem document (``untrusted-host``)
    rather than plain text. The check itself is Starlette's, run as a probe that only marks
    the scope when the host passes."""

    def __init__(self, app: ASGIApp, allowed_hosts: Sequence[str]) -> None:
        self.app = app
        self._probe = TrustedHostMiddleware(_mark_trusted, allowed_hosts, www_redirect=False)
        self._plain = TrustedHostMiddleware(app, allowed_hosts, www_redirect=False)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self._plain(scope, receive, send)
            return
        probe: Scope = dict(scope)
        await self._probe(probe, receive, _discard)
        if probe.get(_TRUSTED):
            await self.app(scope, receive, send)
            return
        problem = Problem(
            400,
            "the Host header names a host this service does not answer for",
            kind="untrusted-host",
            title="Untrusted host",
        )
        await response_for(problem, scope.get("path"))(scope, receive, send)


_TRUSTED = "evomesh.trusted_host"


async def _mark_trusted(scope: Scope, receive: Receive, send: Send) -> None:
    scope[_TRUSTED] = True


async def _discard(message: Message) -> None:
    """Where the probe's own plain-text refusal goes."""
