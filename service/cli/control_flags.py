"""The mesh-control flags of ``evomesh mesh`` (local and remote): refinements and constraints.

``--refine JSON`` (repeatable) adds one ``{"geometry": ..., "size": s}``; ``--refinements FILE``
reads a list of them; ``--constraints FILE`` reads a GeoJSON geometry or FeatureCollection of
(Multi)LineStrings and (Multi)Points. Boundary tags come with the region file itself
(``properties.name`` and ``properties.tags``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

__all__ = ["add_control_flags", "control_inputs"]


def add_control_flags(p: argparse.ArgumentParser | Any) -> None:
    """Add ``--refine``, ``--refinements`` and ``--constraints`` to a parser (or group)."""
    p.add_argument(
        "--refine",
        action="append",
        default=[],
        metavar="JSON",
        help='a local size, {"geometry": <GeoJSON geometry>, "size": s} (repeatable)',
    )
    p.add_argument("--refinements", metavar="FILE", help="a JSON list of refinements")
    p.add_argument(
        "--constraints",
        metavar="FILE",
        help="GeoJSON lines that become mesh edges and points that become mesh nodes",
    )


def _json(text: str, what: str) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{what} is not JSON: {exc}") from None


def control_inputs(args: argparse.Namespace) -> dict[str, Any]:
    """The ``refinements`` and ``constraints`` inputs the flags give (absent when not given)."""
    refinements = [_json(r, f"--refine {r!r}") for r in args.refine]
    if args.refinements:
        listed = _json(Path(args.refinements).read_text(), args.refinements)
        if not isinstance(listed, list):
            raise ValueError(f"{args.refinements} must hold a JSON list of refinements")
        refinements += listed
    out: dict[str, Any] = {}
    if refinements:
        out["refinements"] = refinements
    if args.constraints:
        out["constraints"] = _json(Path(args.constraints).read_text(), args.constraints)
    return out
