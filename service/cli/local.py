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

from ..control import local_payload, refinements_of
from ..control import run_mesh as run_engine
from ..document import cell_data, mesh_from_document, result_document
from ..formats import EXTENSIONS, FORMATS, StoredResult
from ..geojson import BoundaryInputError, parse_region
from .control_flags import add_control_flags, control_inputs
from .files import output_format, read_mesh, say, write_output
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
        method_flag,
        dest="method",
        default=d.method,
        help=f"{' | '.join(engine.SMOOTHERS)} (default {d.method})",
    )
    p.add_argument("--no-swap", action="store_true", help="skip diagonal swapping")
    _add_fitness_flags(p)
    p.add_argument("--population", type=_positive(int), default=d.population)
    p.add_argument("--generations", type=_positive(int), default=d.generations)
    p.add_argument("--crossover-rate", type=_fraction, default=d.crossover_rate)
    p.add_argument("--mutation-rate", type=_fraction, default=d.mutation_rate)
    p.add_argument(
        "--tolerance", type=float, default=d.tolerance, help="stop when a sweep changes less"
    )
    p.add_argument("--max-sweeps", type=_positive(int), default=d.max_sweeps)
    p.add_argument(
        "--threshold", type=float, default=d.threshold, help="evolve only nodes below this fitness"
    )
    p.add_argument(
        "--iterations", type=_positive(int), default=d.iterations, help="Laplacian sweeps"
    )
    p.add_argument("--seed", type=int, default=0, help="random seed of the GA (default 0)")


def _add_fitness_flags(p: argparse.ArgumentParser) -> None:
    d = SmoothingParams()
    p.add_argument(
        "--fitness",
        default=d.fitness,
        help=f"{' | '.join(engine.FITNESS)} (default {d.fitness})",
    )
    p.add_argument("--alpha", type=float, default=d.alpha, help="weight of the angle term")
    p.add_argument("--beta", type=float, default=d.beta, help="weight of the aspect term")


def _add_mesh_input(p: argparse.ArgumentParser) -> None:
    readable = [f.name for f in FORMATS.values() if f.reader is not None]
    p.add_argument(
        "mesh",
        help=f"a mesh with points and triangles: {' | '.join(readable)} by its extension "
        "('-' for a JSON document on standard input)",
    )
    p.add_argument("--input-format", choices=readable, help="read MESH in this format")


def _add_output_flags(p: argparse.ArgumentParser) -> None:
    writable = [f.name for f in FORMATS.values() if f.writer is not None]
    p.add_argument(
        "-o",
        "--output",
        required=True,
        help=f"output file, its extension picks the format: {' '.join(EXTENSIONS)} "
        "('-': standard output, JSON unless --format says otherwise)",
    )
    p.add_argument("--format", choices=writable, help="write in this format whatever the name")


def register(sub: Any) -> None:
    p = sub.add_parser("mesh", help="mesh a region (GeoJSON or {outer, holes} JSON)")
    p.add_argument("region", help="GeoJSON or JSON file ('-' for standard input)")
    p.add_argument("--size", type=_positive(float), help="target edge length (default: h property)")
    p.add_argument("--growth", type=float, default=1.2)
    p.add_argument("--size-min", type=_positive(float))
    p.add_argument("--size-max", type=_positive(float))
    p.add_argument("--wgs84", action="store_true", help="coordinates are lon/lat")
    add_control_flags(p)
    _add_smoothing_flags(p, "--smooth")
    _add_output_flags(p)
    p.set_defaults(handler=run_mesh)

    s = sub.add_parser("smooth", help="swap and smooth an existing mesh")
    _add_mesh_input(s)
    _add_smoothing_flags(s, "--method")
    _add_output_flags(s)
    s.set_defaults(handler=run_smooth)

    q = sub.add_parser("quality", help="print the quality summary of a mesh")
    _add_mesh_input(q)
    q.add_argument("--json", action="store_true", help="print the whole document")
    _add_fitness_flags(q)
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
        threshold=args.threshold,
    )


def _write(doc: dict[str, Any], args: argparse.Namespace) -> None:
    fmt = output_format(args.output, args.format)
    write_output(fmt.render(StoredResult(doc=doc), {}), args.output)


def run_mesh(args: argparse.Namespace) -> int:
    output_format(args.output, args.format)  # a bad name fails before the meshing
    boundary = _read_json(args.region)
    parsed = parse_region(boundary, wgs84=args.wgs84)
    size = args.size if args.size is not None else parsed.properties.get("h")
    if size is None:
        raise ValueError("no --size given and the input has no 'h' property")
    payload = local_payload(boundary, parsed, control_inputs(args), args.wgs84)
    params = PipelineParams(
        sizing=SizingParams(
            float(size),
            args.growth,
            args.size_min,
            args.size_max,
            refinements_of(payload["refinements"]),
        ),
        swap=not args.no_swap,
        smoothing=_smoothing(args),
    )
    with StageBar() as progress:  # a bar on a terminal, once the run takes a while
        rng = np.random.default_rng(args.seed)
        result, tags = run_engine(payload, parsed.region, params, rng, progress, lambda: False)
        doc = result_document(result, parsed.to_lonlat, tags=tags)
        doc["summary"]["parameters"]["seed"] = args.seed
        progress("write", 0.0)
        _write(doc, args)
    s = result.smoothed.summary
    say(
        f"{s['count']} triangles, {s['points']} points, min angle {s['min_angle']['min']:.1f} deg, "
        f"min quality {s['quality']['min']:.3f} -> {args.output}",
        args.output,
    )
    return 0


def run_smooth(args: argparse.Namespace) -> int:
    output_format(args.output, args.format)
    mesh = mesh_from_document(read_mesh(args.mesh, args.input_format))
    result = engine.smooth_mesh(
        mesh, _smoothing(args), swap=not args.no_swap, rng=np.random.default_rng(args.seed)
    )
    doc = result_document(result)
    doc["summary"]["parameters"]["seed"] = args.seed
    _write(doc, args)
    a, b = result.initial.summary, result.smoothed.summary
    angles = f"{a['min_angle']['min']:.1f} -> {b['min_angle']['min']:.1f} deg"
    say(
        f"min quality {a['quality']['min']:.3f} -> {b['quality']['min']:.3f}, "
        f"min angle {angles} -> {args.output}",
        args.output,
    )
    return 0


def run_quality(args: argparse.Namespace) -> int:
    mesh = mesh_from_document(read_mesh(args.mesh, args.input_format))
    fitness = SmoothingParams(fitness=args.fitness, alpha=args.alpha, beta=args.beta)
    snap = engine.assess_mesh(mesh, fitness)
    if args.json:
        doc = {"summary": snap.summary, "cell_data": cell_data(snap)}
        print(json.dumps(doc | {"point_data": {"fitness": snap.fitness.tolist()}}))
        return 0
    s = snap.summary
    print(f"triangles      {s['count']}")
    print(f"points         {s['points']}")
    for key in engine.METRICS:
        v = s[key]
        print(f"{key:14s} min {v['min']:.4f}  p5 {v['p5']:.4f}  mean {v['mean']:.4f}")
    print(f"below 30 deg   {100 * s['share_below_30deg']:.2f}%")
    print(f"quality >=0.91 {100 * s['share_quality_ge_0.91']:.2f}%")
    print(f"inverted       {s['inverted']}")
    fit = s["fitness"]
    if fit["min"] is not None:
        print(f"fitness        min {fit['min']:.4f}  mean {fit['mean']:.4f}  ({fit['function']})")
    return 0
