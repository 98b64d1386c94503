"""``evomesh submit``, ``results``, ``dismiss`` and ``jobs``: the command line as a client of a
running service, on :mod:`service.client`. Progress shows as a bar on a terminal and as plain
lines otherwise; a problem from the service is printed as its title and detail on one line.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..client import DEFAULT_URL, Client, Job, Status
from ..formats import EXTENSIONS
from ..inputs import SmoothingInput
from .control_flags import add_control_flags, control_inputs
from .files import STDIO, output_format, say, write_output
from .model_flags import GA_FLAGS, add_model_flags
from .progress import is_terminal, make_progress, stage_label

__all__ = ["connect", "connection_flags", "mesh_flags", "read_json", "register", "shared_inputs"]


def connection_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--url",
        default=os.environ.get("EVOMESH_URL", DEFAULT_URL),
        help=f"the service (default $EVOMESH_URL or {DEFAULT_URL})",
    )
    p.add_argument("--api-key", default=None, help="API key (default $EVOMESH_API_KEY)")


def connect(args: argparse.Namespace) -> Client:
    return Client(args.url, args.api_key)


def mesh_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("mesh inputs (the service's defaults when left out)")
    g.add_argument("--size", type=float, help="target edge length (default: the h property)")
    g.add_argument("--growth", type=float)
    g.add_argument("--smooth", dest="method", help="smoothing method (see GET /processes/mesh)")
    g.add_argument("--no-swap", action="store_true", help="skip diagonal swapping")
    g.add_argument("--seed", type=int, help="random seed (default: the service picks one)")
    g.add_argument("--wgs84", action="store_true", help="coordinates are lon/lat")
    add_control_flags(g)
    g.add_argument(
        "--crs", help="CRS of the region (EPSG:4326, EPSG:32633...); sizes in metres for lon/lat"
    )
    add_model_flags(
        p.add_argument_group("smoothing (the service's defaults when left out)"),
        SmoothingInput,
        GA_FLAGS,
        defaults=False,
    )
    g.add_argument(
        "--input",
        dest="extra",
        action="append",
        default=[],
        metavar="NAME=JSON",
        help="any other input, e.g. --input smoothing.population=50 (repeatable)",
    )


def _output_flags(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument(
        "-o",
        "--output",
        help=f"write {what} here ('-': standard output); the extension picks the format: "
        + " ".join(EXTENSIONS),
    )
    p.add_argument("--format", help="the result format whatever the file name (json, png...)")
    p.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a picture option, e.g. --option color=min_angle (repeatable)",
    )


def register(sub: Any) -> None:
    s = sub.add_parser(
        "submit",
        help="send a region to a service as a mesh job",
        description="Submit a mesh job for a region (GeoJSON or {outer, holes} JSON) and "
        "optionally wait for it and download its result.",
    )
    s.add_argument("region", help="GeoJSON or JSON file ('-' for standard input)")
    connection_flags(s)
    s.add_argument("--wait", action="store_true", help="follow the job until it ends")
    _output_flags(s, "the result (implies --wait)")
    mesh_flags(s)
    s.set_defaults(handler=run_submit)

    r = sub.add_parser(
        "results",
        help="download a finished job's result",
        description="Write the result of job JOB in the format of the output file's extension "
        "(or --format).",
    )
    r.add_argument("job", metavar="JOB")
    connection_flags(r)
    _output_flags(r, "the result")
    r.set_defaults(handler=run_results)

    d = sub.add_parser("dismiss", help="cancel jobs and forget their results")
    d.add_argument("jobs", nargs="+", metavar="JOB")
    connection_flags(d)
    d.set_defaults(handler=run_dismiss)

    j = sub.add_parser("jobs", help="list a service's jobs, newest first")
    connection_flags(j)
    j.add_argument("--status", action="append", help="only this status (repeatable)")
    j.add_argument("--limit", type=int, default=20, help="how many (default 20)")
    j.set_defaults(handler=run_jobs)


# -- inputs ---------------------------------------------------------------------------------------


def read_json(path: str) -> Any:
    """A JSON file (``-``: standard input); ValueError (one line, exit 2) when it is not."""
    try:
        text = sys.stdin.read() if path == STDIO else Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror or exc}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path} is not JSON: {exc}") from None


def _set(inputs: dict[str, Any], dotted: str, value: Any) -> None:
    *parents, name = dotted.split(".")
    for key in parents:
        inputs = inputs.setdefault(key, {})
    inputs[name] = value


def shared_inputs(args: argparse.Namespace) -> dict[str, Any]:
    """The mesh inputs given by flags (those left out are the service's defaults)."""
    inputs: dict[str, Any] = control_inputs(args)
    for name in ("size", "growth"):
        if getattr(args, name) is not None:
            inputs[name] = getattr(args, name)
    if args.no_swap:
        inputs["swap"] = False
    if args.wgs84:
        inputs["coordinates"] = "wgs84"
    if args.crs:
        inputs["crs"] = args.crs
    for name in GA_FLAGS:  # generated flags: present only when given
        if name in vars(args):
            _set(inputs, f"smoothing.{name}", getattr(args, name))
    if args.method is not None:
        _set(inputs, "smoothing.method", args.method)
    if args.seed is not None:
        _set(inputs, "smoothing.seed", args.seed)
    for item in args.extra:
        name, sep, raw = item.partition("=")
        if not sep or not name:
            raise ValueError(f"--input wants NAME=JSON, got {item!r}")
        try:
            value = json.loads(raw)
        except json.JSONDecodeError:
            value = raw  # a bare word: a string
        _set(inputs, name.strip(), value)
    return inputs


def _options(items: list[str]) -> dict[str, str]:
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise ValueError(f"--option wants NAME=VALUE, got {item!r}")
        out[name.strip()] = value
    return out


def summary_line(doc: dict[str, Any]) -> str:
    """A mesh document in one line: its size and worst figures."""
    s = doc.get("summary", {}).get("smoothed") or doc.get("summary", {}).get("mesh") or {}
    if not s:
        return f"{len(doc.get('triangles', [])):,} triangles"
    return (
        f"{s['count']:,} triangles, min quality {s['quality']['min']:.3f}, "
        f"min angle {s['min_angle']['min']:.1f} deg"
    )


# -- submit and results ---------------------------------------------------------------------------


def _stage(status: Status) -> str:
    return "accepted" if status.status == "accepted" else status.message


def follow(job: Job) -> Status:
    """Wait for a job: a bar on a terminal, a line per stage otherwise; JobFailed if it fails."""
    if is_terminal():
        with make_progress(transient=True) as bar:
            task = bar.add_task(f"job {job.id[:8]}: queued", total=100)

            def show(s: Status) -> None:
                label = f"job {job.id[:8]}: {stage_label(_stage(s))}"
                bar.update(task, completed=s.progress, description=label)

            return job.wait(progress=show)
    last: list[str] = []

    def line(s: Status) -> None:
        if not s.done and _stage(s) not in last[-1:]:
            print(f"job {job.id}: {stage_label(_stage(s))} {s.progress}%", file=sys.stderr)
            last.append(_stage(s))

    return job.wait(progress=line)


def _download(job: Job, args: argparse.Namespace) -> None:
    fmt = output_format(args.output, args.format)
    data = job.result(fmt.name, **_options(args.option))
    write_output(data, args.output)
    what = summary_line(json.loads(data)) if fmt.name == "json" else f"{len(data):,} bytes"
    say(f"job {job.id}: {what} -> {args.output}", args.output)


def run_submit(args: argparse.Namespace) -> int:
    if args.output:
        output_format(args.output, args.format)  # a bad extension fails before anything is sent
    region = read_json(args.region)
    with connect(args) as client:
        job = client.mesh(region, **shared_inputs(args))
        if not (args.wait or args.output):
            print(job.id)
            return 0
        print(f"job {job.id} submitted to {client.url}", file=sys.stderr)
        try:
            follow(job)
        except KeyboardInterrupt:
            print(f"\nthe job goes on; see: evomesh jobs --url {client.url}", file=sys.stderr)
            raise
        if args.output:
            _download(job, args)
        else:
            print(f"job {job.id}: successful")
    return 0


def run_results(args: argparse.Namespace) -> int:
    if args.output is None:
        args.output = STDIO
    output_format(args.output, args.format)
    with connect(args) as client:
        _download(client.job(args.job), args)
    return 0


def run_dismiss(args: argparse.Namespace) -> int:
    with connect(args) as client:
        for job_id in args.jobs:
            status = client.job(job_id).dismiss()
            print(f"job {status.job_id}: {status.status}")
    return 0


# -- jobs -----------------------------------------------------------------------------------------

_COLOURS = {"successful": "green", "failed": "red", "running": "cyan", "dismissed": "dim"}


def run_jobs(args: argparse.Namespace) -> int:
    with connect(args) as client:
        params: dict[str, Any] = {"limit": args.limit}
        if args.status:
            params["status"] = args.status
        doc = client.get_json("/jobs", **params)
    rows: list[tuple[str, ...]] = [
        (
            str(job["jobID"]),
            str(job["processID"]),
            str(job["status"]),
            f"{job['progress']}%",
            str(job.get("created") or "")[:19].replace("T", " "),
            str(job.get("message") or ""),
        )
        for job in doc["jobs"]
    ]
    header = ("JOB", "PROCESS", "STATUS", "PROGRESS", "CREATED (UTC)", "MESSAGE")
    if is_terminal(sys.stdout):
        _table(header, rows, lambda row: _COLOURS.get(row[2], ""))
    else:
        widths = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header) - 1)]
        for row in [header, *rows]:
            cells = [str(c).ljust(w) for c, w in zip(row, widths, strict=False)]
            print("  ".join([*cells, str(row[-1])]).rstrip())
    shown, total = len(rows), doc["numberMatched"]
    if total > shown:
        print(f"({shown} of {total}; --limit for more)", file=sys.stderr)
    return 0


def _table(
    header: tuple[str, ...], rows: list[tuple[str, ...]], style: Callable[[Any], str]
) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(*header, box=None, header_style="bold", pad_edge=False)
    for row in rows:
        table.add_row(*row, style=style(row))
    Console().print(table)
