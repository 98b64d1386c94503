"""Files of the command line: meshes read in any readable format, results written in any
writable one (from the format table), and ``-`` for standard input or output.

>>> [output_format(path, name).name for path, name in [("a.msh", None), ("-", None), ("-", "png")]]
['msh', 'json', 'png']
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from ..formats import FORMATS, ResultFormat, UnknownFormat, format_named, format_of

__all__ = ["STDIO", "input_format", "output_format", "read_mesh", "say", "write_output"]

#: The file name that means standard input or output.
STDIO = "-"


def output_format(path: str, name: str | None) -> ResultFormat:
    """The format to write ``path`` in: ``name`` if given, else from the extension (JSON on
    standard output). Fails (:class:`~service.formats.UnknownFormat`) before any work is done."""
    if name is not None:
        fmt = format_named(name)
    elif path == STDIO:
        fmt = FORMATS["json"]
    else:
        fmt = format_of(path, "output")
    if fmt.writer is None:
        raise UnknownFormat(f"format {fmt.name!r} cannot be written")
    return fmt


def input_format(path: str, name: str | None) -> ResultFormat:
    """The format to read ``path`` in: ``name`` if given, else from the extension (JSON on
    standard input)."""
    if name is not None:
        return format_named(name)
    return FORMATS["json"] if path == STDIO else format_of(path, "input")


def read_mesh(path: str, name: str | None = None) -> dict[str, Any]:
    """The mesh document in ``path`` (``-``: standard input), in any readable format."""
    fmt = input_format(path, name)
    data = sys.stdin.buffer.read() if path == STDIO else Path(path).read_bytes()
    return fmt.read(data)


def write_output(data: bytes, path: str) -> None:
    """Write ``data`` to ``path`` (``-``: standard output)."""
    if path == STDIO:
        sys.stdout.flush()
        sys.stdout.buffer.write(data)
        sys.stdout.buffer.flush()
    else:
        Path(path).write_bytes(data)


def say(line: str, output: str | None) -> None:
    """Print a command's summary line: on standard error when the result goes to standard output."""
    print(line, file=sys.stderr if output == STDIO else sys.stdout)
