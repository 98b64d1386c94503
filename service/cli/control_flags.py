"""The mesh-control flags of ``evomesh mesh`` (local and remote): refinements and constraints.

``--refine JSON`` (repeatable) adds one ``{"geometry": ..., "size": s}`` (with an optional
``"growth"`` of its own); ``--refinements FILE``
reads a list of them; ``--constraints FILE`` reads a GeoJSON geometry or FeatureCollection of
(Multi)LineStrings and (Multi)Points. Boundary tags come with the region file itself
(``properties.name`` and ``properties.tags``). ``--resample`` (and ``--resample-tolerance``)
re-discretises a digitised boundary to the size instead of keeping every vertex.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

__all__ = ["add_control_flags", "control_inputs"]


def add_control_flags(p: argparse.ArgumentParser | Any) -> None:
    """Add ``--refine``, ``--refinements``, ``--constraints``, ``--resample`` and
    ``--resample-tolerance`` to a parser (or group)."""
    p.add_argument(
        "--refine",
        action="append",
        default=[],
        metavar="JSON",
        help='a local size, {"geometry": <GeoJSON geometry>, "size": s} with an optional'
        ' "growth" (default the job\'s) (repeatable)',
    )
    p.add_argument("--refinements", metavar="FILE", help="a JSON list of refinements")
    p.add_argument(
        "--constraints",
        metavar="FILE",
        help="GeoJSON lines that become mesh edges and points that become mesh nodes",
    )
    p.add_argument(
        "--resample",
        action="store_true",
        help="re-discretise the boundary to the size (corners kept) instead of keeping every"
        " vertex: for digitised boundaries with vertices far closer than the size",
    )
    p.add_argument(
        "--resample-tolerance",
        type=float,
        metavar="D",
        help="with --resample, largest distance of the meshed boundary from the input"
        " (default 0.1 of the size)",
    )


def _json(text: str, what: str) -> Any:
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{what} is not JSON: {exc}") from None


def control_inputs(args: argparse.Namespace) -> dict[str, Any]:
    """The ``refinements``, ``constraints``, ``resample`` and ``resample_tolerance`` inputs the
    flags give (absent when not given)."""
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
    if args.resample_tolerance is not None and not args.resample_tolerance > 0:
        raise ValueError(f"--resample-tolerance must be positive, got {args.resample_tolerance}")
    if args.resample:
        out["resample"] = True
    if args.resample_tolerance is not None:
        out["resample_tolerance"] = args.resample_tolerance
    return out
