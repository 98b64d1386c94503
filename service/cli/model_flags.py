"""Command-line flags generated from a request model's fields, so the CLI offers what the API
does, with the same defaults, descriptions and validation (issue 14).

A field ``mutation_rate`` becomes ``--mutation-rate``; a field that may be null takes ``none``;
a ``Literal`` field lists its choices. The values are checked by building the model, so a bad
value is refused with the API's own message.
"""

from __future__ import annotations

import argparse
import types
import typing
from collections.abc import Callable, Iterable
from typing import Any

from pydantic import BaseModel
from pydantic.fields import FieldInfo

from ..inputs import SmoothingInput

__all__ = ["GA_FLAGS", "MESH_FLAGS", "add_model_flags", "model_values"]

#: The smoothing input's fields offered as flags of their own (method, fitness and seed have
#: hand-written flags: their names or defaults differ between commands).
GA_FLAGS = [
    name
    for name in SmoothingInput.model_fields
    if name not in {"method", "fitness", "alpha", "beta", "seed"}
]

#: The mesh input's sizing fields offered as flags of their own (the boundary is the command's
#: argument; swap, lon/lat, smoothing, refinements and constraints have flags of their own).
MESH_FLAGS = ["crs", "size", "growth", "size_min", "size_max"]


def _parser(kind: Any, nullable: bool) -> Callable[[str], Any]:
    def parse(text: str) -> Any:
        if nullable and text.strip().lower() in {"none", "null"}:
            return None
        return kind(text)

    parse.__name__ = getattr(kind, "__name__", "value")  # argparse names it in errors
    return parse


def _shape(info: FieldInfo) -> tuple[Callable[[str], Any], list[Any] | None, bool]:
    """(text -> value, choices, nullable) of a field."""
    annotation = info.annotation
    args = typing.get_args(annotation)
    nullable = type(None) in args and (
        typing.get_origin(annotation) in {typing.Union, types.UnionType}
    )
    if nullable:
        annotation = next(a for a in args if a is not type(None))
    if typing.get_origin(annotation) is typing.Literal:
        choices = list(typing.get_args(annotation))
        return _parser(type(choices[0]), nullable), choices, nullable
    kind = annotation if annotation in {int, float, str} else str
    return _parser(kind, nullable), None, nullable


def add_model_flags(
    p: argparse.ArgumentParser | Any,
    model: type[BaseModel],
    names: Iterable[str],
    *,
    defaults: bool = True,
) -> None:
    """Add ``--name`` for each of ``model``'s fields ``names``; with ``defaults=False`` an
    absent flag stays ``None`` (the service's default applies)."""
    for name in names:
        info = model.model_fields[name]
        parse, choices, nullable = _shape(info)
        default = info.get_default(call_default_factory=True)
        help_text = info.description or name.replace("_", " ")
        if defaults:
            help_text += f" (default {'none' if default is None else default})"
        if nullable and default is not None:  # then null means "no limit"
            help_text += "; 'none' for no limit"
        p.add_argument(
            "--" + name.replace("_", "-"),
            dest=name,
            type=parse,
            choices=choices,
            default=default if defaults else argparse.SUPPRESS,
            metavar=None if choices else name.upper(),
            help=help_text.replace("%", "%%"),
        )


def model_values(args: argparse.Namespace, model: type[BaseModel]) -> dict[str, Any]:
    """The values of ``model``'s fields present in ``args`` (given or defaulted)."""
    given = vars(args)
    return {name: given[name] for name in model.model_fields if name in given}
