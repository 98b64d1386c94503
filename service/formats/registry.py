"""The format table: one entry per format, keyed by name and by file extension (as meshio's).

A format has a ``writer`` (a stored mesh document to bytes), a ``reader`` (bytes to a mesh
document), or both. The API's results route and the command line both look formats up here.

>>> register_format("txt", [".txt"], "text/plain", writer=lambda r, o: b"3 points")
ResultFormat(name='txt', extensions=('.txt',), ...)
>>> format_of("mesh.TXT").name
'txt'
>>> del FORMATS["txt"], EXTENSIONS[".txt"]
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import orjson

__all__ = [
    "EXTENSIONS",
    "FORMATS",
    "FormatError",
    "ReadError",
    "Reader",
    "ResultFormat",
    "StoredResult",
    "UnknownFormat",
    "WriteError",
    "Writer",
    "format_named",
    "format_of",
    "register_format",
]


class FormatError(ValueError):
    """A format cannot do what was asked; ``parameter`` names the request option at fault."""

    def __init__(self, message: str, parameter: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.parameter = parameter


class UnknownFormat(FormatError):
    """No format has this name or extension, or the one found cannot read (or write)."""


class ReadError(FormatError):
    """The bytes are not a mesh in the format they claim."""


class WriteError(FormatError):
    """The document cannot be written in this format (or with these options)."""


class StoredResult:
    """A result document: its JSON bytes and the parsed document, each made on first use.

    >>> StoredResult(doc={"points": []}).raw
    b'{"points":[]}'
    """

    def __init__(self, raw: bytes | None = None, doc: dict[str, Any] | None = None) -> None:
        if raw is None and doc is None:
            raise TypeError("a StoredResult needs raw bytes or a document")
        if raw is not None:
            self.__dict__["raw"] = raw  # cached_property reads the instance dict first
        if doc is not None:
            self.__dict__["doc"] = doc

    @cached_property
    def raw(self) -> bytes:
        return orjson.dumps(self.doc)

    @cached_property
    def doc(self) -> dict[str, Any]:
        value: dict[str, Any] = orjson.loads(self.raw)
        return value


#: ``writer(result, options) -> bytes``; options are the request's query parameters.
Writer = Callable[[StoredResult, Mapping[str, str]], bytes]
#: ``reader(data) -> document`` holding at least ``points`` and ``triangles``.
Reader = Callable[[bytes], dict[str, Any]]


@dataclass(frozen=True)
class ResultFormat:
    """One format of the table."""

    name: str  #: the ``f`` query value and the ``--format`` flag
    extensions: tuple[str, ...]  #: file name endings, lower case; the first names downloads
    media_type: str
    reader: Reader | None = field(default=None, repr=False)
    writer: Writer | None = field(default=None, repr=False)
    description: str = field(default="", repr=False)

    @property
    def extension(self) -> str:
        """The extension of a download's file name."""
        return self.extensions[0]

    def render(self, result: StoredResult, options: Mapping[str, str]) -> bytes:
        """``result`` in this format; :class:`UnknownFormat` when it cannot be written."""
        if self.writer is None:
            raise UnknownFormat(f"format {self.name!r} cannot be written", "f")
        return self.writer(result, options)

    def read(self, data: bytes) -> dict[str, Any]:
        """The mesh document in ``data``; :class:`UnknownFormat` when it cannot be read."""
        if self.reader is None:
            readable = ", ".join(f.name for f in FORMATS.values() if f.reader is not None)
            raise UnknownFormat(f"format {self.name!r} cannot be read; use one of {readable}")
        return self.reader(data)


#: Formats by name, in registration order.
FORMATS: dict[str, ResultFormat] = {}
#: Formats by file extension (lower case, with the dot).
EXTENSIONS: dict[str, ResultFormat] = {}


def register_format(
    name: str,
    extensions: Iterable[str],
    media_type: str,
    *,
    reader: Reader | None = None,
    writer: Writer | None = None,
    description: str = "",
) -> ResultFormat:
    """Add (or replace) a format; it is found by ``name`` and by each of ``extensions``."""
    exts = tuple(e.lower() for e in extensions)
    fmt = ResultFormat(name, exts, media_type, reader, writer, description)
    FORMATS[name] = fmt
    for ext in exts:
        EXTENSIONS[ext] = fmt
    return fmt


def format_named(name: str) -> ResultFormat:
    """The format called ``name``; :class:`UnknownFormat` when none is.

    >>> format_named("vtk")
    Traceback (most recent call last):
    ...
    service.formats.registry.UnknownFormat: unknown format 'vtk'; choose one of geojson, json, ...
    """
    fmt = FORMATS.get(name)
    if fmt is None:
        raise UnknownFormat(f"unknown format {name!r}; choose one of {', '.join(sorted(FORMATS))}")
    return fmt


def format_of(path: str | Path, role: str = "file") -> ResultFormat:
    """The format of a file, from its extension; :class:`UnknownFormat` when none has it.

    >>> format_of("mesh.vtk", "output")
    Traceback (most recent call last):
    ...
    service.formats.registry.UnknownFormat: unsupported output format '.vtk'; use one of ...
    """
    suffix = Path(path).suffix.lower()
    fmt = EXTENSIONS.get(suffix)
    if fmt is None:
        known = " ".join(sorted(EXTENSIONS))
        raise UnknownFormat(
            f"unsupported {role} format {suffix or str(path)!r}; use one of {known}"
        )
    return fmt
