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
from ..geo import read_region_file
from ..geojson import BoundaryInputError, parse_region, region_crs
from ..inputs import SmoothingInput
from .control_flags import add_control_flags, control_inputs
from .files import output_format, read_mesh, say, write_output
from .model_flags import GA_FLAGS, add_model_flags, model_values
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
    add_model_flags(p.add_argument_group("smoothing"), SmoothingInput, GA_FLAGS)
    p.add_argument("--seed", type=int, default=0, help="random seed of the GA (default 0)")


def _add_fitness_flags(p: argparse.ArgumentParser) -> None:
    d = SmoothingParams()
    p.add_argument(
        "--fitness",
        default=d.fitness,
        help=f"{' | '.join(engine.FITNESS)} (default {d.fitness})",
    )
    add_model_flags(p, SmoothingInput, ["alpha", "beta"])


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
    p = sub.add_parser(
        "mesh", help="mesh a region (GeoJSON, {outer, holes} JSON, GeoPackage, Shapefile, KML)"
    )
    p.add_argument(
        "region",
        help="GeoJSON or JSON file ('-' for standard input), or .gpkg/.shp/.kml (needs pyogrio)",
    )
    p.add_argument("--layer", help="the layer of a multi-layer file (default: the first)")
    p.add_argument(
        "--crs",
        help="CRS of the region (EPSG:4326, EPSG:32633, WKT, PROJ...); default: the file's own, "
        "else planar. Lon/lat is meshed in metres (sizes in metres); results are in this CRS",
    )
    p.add_argument("--size", type=_positive(float), help="target edge length (default: h property)")
    p.add_argument("--growth", type=float, default=1.2)
    p.add_argument("--size-min", type=_positive(float))
    p.add_argument("--size-max", type=_positive(float))
    p.add_argument("--wgs84", action="store_true", help="coordinates are lon/lat (--crs OGC:CRS84)")
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
    """The engine's parameters from the flags, checked by the API's own model."""
    values = SmoothingInput(**model_values(args, SmoothingInput)).model_dump()
    values.pop("seed")
    return SmoothingParams(**values)


def _write(doc: dict[str, Any], args: argparse.Namespace) -> None:
    fmt = output_format(args.output, args.format)
    write_output(fmt.render(StoredResult(doc=doc), {}), args.output)


def run_mesh(args: argparse.Namespace) -> int:
    output_format(args.output, args.format)  # a bad name fails before the meshing
    if args.region == "-":
        boundary, file_crs = _read_json(args.region), None
    else:
        found = read_region_file(args.region, layer=args.layer)
        boundary, file_crs = found.geojson, found.crs
    crs = region_crs(boundary, args.crs or file_crs, "wgs84" if args.wgs84 else "planar")
    parsed = parse_region(boundary, crs=crs)
    size = args.size if args.size is not None else parsed.properties.get("h")
    if size is None:
        raise ValueError("no --size given and the input has no 'h' property")
    if parsed.projection is not None and parsed.projection.geographic:
        parsed = parse_region(boundary, crs=crs, densify=float(size))  # follow lon/lat edges
    payload = local_payload(boundary, parsed, control_inputs(args), float(size))
    params = PipelineParams(
        sizing=SizingParams(
            float(size),
            args.growth,
            args.size_min,
            args.size_max,
            refinements_of(payload["refinements"]),
            resample=args.resample,
            resample_tolerance=args.resample_tolerance,
        ),
        swap=not args.no_swap,
        smoothing=_smoothing(args),
    )
    with StageBar() as progress:  # a bar on a terminal, once the run takes a while
        rng = np.random.default_rng(args.seed)
        result, tags = run_engine(payload, parsed.region, params, rng, progress, lambda: False)
        doc = result_document(result, parsed.crs(), tags=tags)
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
