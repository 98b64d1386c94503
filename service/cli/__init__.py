"""The ``evomesh`` command line: local meshing and smoothing, the server, and the client."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from importlib.metadata import PackageNotFoundError, version

from ..client import ClientError, ProblemError
from . import batch, client, local, serve

__all__ = ["CliError", "build_parser", "main"]


class CliError(Exception):
    """A user error: printed as one line, exit code 2."""


def package_version() -> str:
    try:
        return version("evomesh")
    except PackageNotFoundError:  # running from a source tree that was never installed
        return "0+unknown"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="evomesh",
        description="Triangular meshing of planar regions with genetic-algorithm smoothing.",
    )
    parser.add_argument("--version", action="version", version=f"evomesh {package_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module in (local, serve, client, batch):
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        code: int = args.handler(args)
    except KeyboardInterrupt:
        print("evomesh: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (``| head``): not an error worth a traceback
        _silence_stdout()
        return 1
    except ClientError as exc:  # the service said no, or could not be reached
        print(f"evomesh: error: {exc.line}", file=sys.stderr)
        return exit_code(exc)
    except local.USER_ERRORS as exc:
        message = " ".join(str(exc).split())
        print(f"evomesh: error: {message}", file=sys.stderr)
        return 2
    return code


def exit_code(exc: ClientError) -> int:
    """2 when the service refused the request (4xx: the input's fault), 1 otherwise.

    >>> exit_code(ProblemError({"status": 422})), exit_code(ProblemError({"status": 503}))
    (2, 1)
    """
    return 2 if isinstance(exc, ProblemError) and 400 <= exc.status < 500 else 1


def _silence_stdout() -> None:
    """Point standard output at /dev/null, so the interpreter's final flush cannot fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout is not a real file (a test's capture): nothing to do
        pass
    finally:
        os.close(devnull)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
