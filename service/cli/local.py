"""``evomesh mesh``, ``evomesh smooth`` and ``evomesh quality``: the engine on local files."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

import engine
from engine import EngineError, PipelineParams, SizingParams, SmoothingParams

from ..document import CELL_FIELDS, mesh_from_document, result_document
from ..geojson import BoundaryInputError, parse_region
from .progress import StageBar

#: Errors that are the user's, printed on one line with exit code 2.
USER_ERRORS = (EngineError, BoundaryInputError, ValueError, OSError, json.JSONDecodeError)


def _positive(kind: type) -> Any:
    def check(text: str) -> Any:
        value = kind(text)
        if not value > 0:
            raise argparse.ArgumentTypeError(f"must be positive, got {text}")
        return value

    return check


def _fraction(text: str) -> float:
    value = float(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be within [0, 1], got {text}")
    return value


def _add_smoothing_flags(p: argparse.ArgumentParser, method_flag: str) -> None:
    d = SmoothingParams()
    p.add_argument(
        method_flag, dest="method", default=d.method, help=f"smoother (default {d.method})"
    )
    p.add_argument("--no-swap", action="store_true", help="skip diagonal swapping")
    p.add_argument("--fitness", default=d.fitness, help="angle | aspect | combined | worst")
    p.add_argument("--alpha", type=float, default=d.alpha)
    p.add_argument("--beta", type=float, default=d.beta)
    p.add_argument("--population", type=_positive(int), default=d.population)
    p.add_argument("--generations", type=_positive(int), default=d.generations)
    p.add_argument("--crossover-rate", type=_fraction, default=d.crossover_rate)
    p.add_argument("--mutation-rate", type=_fraction, default=d.mutation_rate)
    p.add_argument("--tolerance", type=float, default=d.tolerance)
    p.add_argument("--max-sweeps", type=_positive(int), default=d.max_sweeps)
    p.add_argument("--iterations", type=_positive(int), default=d.iterations)
    p.add_argument("--seed", type=int, default=0)


def register(sub: Any) -> None:
    p = sub.add_parser("mesh", help="mesh a region (GeoJSON or {outer, holes} JSON)")
    p.add_argument("region", help="GeoJSON or JSON file ('-' for standard input)")
    p.add_argument("--size", type=_positive(float), help="target edge length (default: h property)")
    p.add_argument("--growth", type=float, default=1.2)
    p.add_argument("--size-min", type=_positive(float))
    p.add_argument("--size-max", type=_positive(float))
    p.add_argument("--wgs84", action="store_true", help="coordinates are lon/lat")
    _add_smoothing_flags(p, "--smooth")
    p.add_argument("-o", "--output", required=True, help="output file: .json, .png or .svg")
    p.set_defaults(handler=run_mesh)

    s = sub.add_parser("smooth", help="swap and smooth an existing mesh document")
    s.add_argument("mesh", help="mesh JSON with points and triangles")
    _add_smoothing_flags(s, "--method")
    s.add_argument("-o", "--output", required=True)
    s.set_defaults(handler=run_smooth)

    q = sub.add_parser("quality", help="print the quality summary of a mesh document")
    q.add_argument("mesh")
    q.add_argument("--json", action="store_true", help="print the whole document")
    q.set_defaults(handler=run_quality)


def _read_json(path: str) -> Any:
    text = sys.stdin.read() if path == "-" else Path(path).read_text()
    return json.loads(text)


def _smoothing(args: argparse.Namespace) -> SmoothingParams:
    return SmoothingParams(
        method=args.method,
        fitness=args.fitness,
        alpha=args.alpha,
        beta=args.beta,
        population=args.population,
        generations=args.generations,
        crossover_rate=args.crossover_rate,
        mutation_rate=args.mutation_rate,
        tolerance=args.tolerance,
        max_sweeps=args.max_sweeps,
        iterations=args.iterations,
    )


def _write(doc: dict[str, Any], path: str) -> None:
    out = Path(path)
    suffix = out.suffix.lower()
    if suffix == ".json":
        out.write_text(json.dumps(doc))
    elif suffix in (".png", ".svg"):  # a picture, coloured by quality
        from ..render import render_picture

        out.write_bytes(render_picture(doc, "png" if suffix == ".png" else "svg"))
    else:
        raise ValueError(f"unsupported output format {out.suffix!r}; use .json, .png or .svg")


def run_mesh(args: argparse.Namespace) -> int:
    parsed = parse_region(_read_json(args.region), wgs84=args.wgs84)
    size = args.size if args.size is not None else parsed.properties.get("h")
    if size is None:
        raise ValueError("no --size given and the input has no 'h' property")
    params = PipelineParams(
        sizing=SizingParams(float(size), args.growth, args.size_min, args.size_max),
        swap=not args.no_swap,
        smoothing=_smoothing(args),
    )
    with StageBar() as progress:  # a bar on a terminal, once the run takes a while
        result = engine.mesh_then_smooth(
            parsed.region, params, np.random.default_rng(args.seed), progress=progress
        )
        doc = result_document(result, parsed.to_lonlat)
        doc["summary"]["parameters"]["seed"] = args.seed
        progress("write", 0.0)
        _write(doc, args.output)
    s = result.smoothed.summary
    print(
        f"{s['count']} triangles, {s['points']} points, min angle {s['min_angle']['min']:.1f} deg, "
        f"min quality {s['quality']['min']:.3f} -> {args.output}"
    )
    return 0


def run_smooth(args: argparse.Namespace) -> int:
    mesh = mesh_from_document(_read_json(args.mesh))
    result = engine.smooth_mesh(
        mesh, _smoothing(args), swap=not args.no_swap, rng=np.random.default_rng(args.seed)
    )
    doc = result_document(result)
    doc["summary"]["parameters"]["seed"] = args.seed
    _write(doc, args.output)
    a, b = result.initial.summary, result.smoothed.summary
    print(
        f"min quality {a['quality']['min']:.3f} -> {b['quality']['min']:.3f}, "
        f"min angle {a['min_angle']['min']:.1f} -> {b['min_angle']['min']:.1f} deg -> {args.output}"
    )
    return 0


def run_quality(args: argparse.Namespace) -> int:
    mesh = mesh_from_document(_read_json(args.mesh))
    snap = engine.assess_mesh(mesh)
    if args.json:
        cells = {k: getattr(snap.quality, k).tolist() for k in CELL_FIELDS}
        doc = {"summary": snap.summary, "cell_data": cells}
        print(json.dumps(doc | {"point_data": {"fitness": snap.fitness.tolist()}}))
        return 0
    s = snap.summary
    print(f"triangles      {s['count']}")
    print(f"points         {s['points']}")
    for key in ("quality", "radius_ratio", "min_angle", "max_angle"):
        v = s[key]
        print(f"{key:14s} min {v['min']:.4f}  p5 {v['p5']:.4f}  mean {v['mean']:.4f}")
    print(f"below 30 deg   {100 * s['share_below_30deg']:.2f}%")
    print(f"inverted       {s['inverted']}")
    return 0
