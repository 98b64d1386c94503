"""``evomesh mesh``, ``evomesh smooth`` and ``evomesh quality``: the processes on local files.

Each command builds the process's own inputs model from its flags (generated from the model)
and runs the same ``prepare`` and ``execute`` as a job of the service, with no limits but the
engine's own; a refused input is one line naming the input at fault.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

import engine
from engine import EngineError, SmoothingParams

from ..formats import EXTENSIONS, FORMATS, StoredResult
from ..geo import read_region_file
from ..geojson import BoundaryInputError
from ..inputs import SmoothingInput
from ..processes import inputs_at, mesh, quality, smooth
from ..refusal import InputRefused
from ..settings import Settings
from .control_flags import add_control_flags, control_inputs
from .files import output_format, read_mesh, say, write_output
from .model_flags import GA_FLAGS, MESH_FLAGS, add_model_flags, model_values
from .progress import StageBar

#: Errors that are the user's, printed on one line with exit code 2.
USER_ERRORS = (EngineError, BoundaryInputError, ValueError, OSError, json.JSONDecodeError)

#: Inputs are found at the top level of what the flags give (``/size``, ``/refinements/0``).
WHERE = inputs_at("")

M = TypeVar("M", bound=BaseModel)
T = TypeVar("T")


def _local_limits() -> Settings:
    """No limits on local files but the engine's own (its triangle limit)."""
    unbounded = 2**62
    return Settings(
        _env_file=None,
        max_vertices=unbounded,
        max_rings=unbounded,
        max_triangles=engine.PipelineParams(engine.SizingParams(1.0)).max_triangles,
        max_ga_work=1e300,
        ga_rate=1e300,
    )


def _model(model: type[M], values: dict[str, Any]) -> M:
    """``values`` checked by the API's own model; its first error as a one-line ValueError."""
    try:
        return model.model_validate(values)
    except ValidationError as exc:
        first = exc.errors(include_url=False)[0]
        where = "".join(f"/{part}" for part in first["loc"])
        raise ValueError(f"{where}: {first['msg']}") from None


def _prepared(prepare: Callable[[M, Settings, Any], tuple[T, int]], inputs: M) -> T:
    """The typed request of ``inputs``; a refusal as a one-line ValueError naming the input."""
    try:
        request, _ = prepare(inputs, _local_limits(), WHERE)
    except InputRefused as exc:
        raise ValueError(f"{exc.pointer}: {exc.detail}" if exc.pointer else exc.detail) from None
    return request


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
    add_model_flags(p, mesh.MeshInputs, MESH_FLAGS)
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


def _smoothing(args: argparse.Namespace) -> dict[str, Any]:
    """The smoothing input the flags give (checked with the rest of the inputs)."""
    return model_values(args, SmoothingInput)


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
    values = {name: getattr(args, name) for name in MESH_FLAGS}
    values.update(
        boundary=boundary,
        crs=args.crs or file_crs,
        coordinates="wgs84" if args.wgs84 else "planar",
        swap=not args.no_swap,
        smoothing=_smoothing(args),
        **control_inputs(args),
    )
    request = _prepared(mesh.prepare, _model(mesh.MeshInputs, values))
    with StageBar() as progress:  # a bar on a terminal, once the run takes a while
        doc = mesh.execute(request, progress, lambda: False)
        progress("write", 0.0)
        _write(doc, args)
    s = doc["summary"]["smoothed"]
    say(
        f"{s['count']} triangles, {s['points']} points, min angle {s['min_angle']['min']:.1f} deg, "
        f"min quality {s['quality']['min']:.3f} -> {args.output}",
        args.output,
    )
    return 0


def run_smooth(args: argparse.Namespace) -> int:
    output_format(args.output, args.format)
    values = {
        "mesh": read_mesh(args.mesh, args.input_format),
        "swap": not args.no_swap,
        "smoothing": _smoothing(args),
    }
    doc = smooth.execute(_prepared(smooth.prepare, _model(smooth.SmoothInputs, values)))
    _write(doc, args)
    a, b = doc["summary"]["initial"], doc["summary"]["smoothed"]
    angles = f"{a['min_angle']['min']:.1f} -> {b['min_angle']['min']:.1f} deg"
    say(
        f"min quality {a['quality']['min']:.3f} -> {b['quality']['min']:.3f}, "
        f"min angle {angles} -> {args.output}",
        args.output,
    )
    return 0


def run_quality(args: argparse.Namespace) -> int:
    values = {
        "mesh": read_mesh(args.mesh, args.input_format),
        "fitness": args.fitness,
        "alpha": args.alpha,
        "beta": args.beta,
    }
    doc = quality.execute(_prepared(quality.prepare, _model(quality.QualityInputs, values)))
    s = doc["summary"]["mesh"]
    if args.json:
        fitness = {"fitness": doc["point_data"]["fitness"]}
        print(json.dumps({"summary": s, "cell_data": doc["cell_data"], "point_data": fitness}))
        return 0
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
