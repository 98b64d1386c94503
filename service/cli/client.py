"""``evomesh submit``, ``evomesh batch`` and ``evomesh jobs``: the command line as a client of
a running service. Progress shows as bars on a terminal and as plain lines otherwise; a problem
from the service is printed as its title and detail on one line, with a non-zero exit status.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .api import DEFAULT_URL, Api, ClientError, format_for
from .progress import is_terminal, make_progress, stage_label

__all__ = ["register"]

FINAL = ("successful", "failed", "dismissed")
#: Seconds between two looks at a job's status.
POLL = 0.25


def _connection_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--url",
        default=os.environ.get("EVOMESH_URL", DEFAULT_URL),
        help=f"the service (default $EVOMESH_URL or {DEFAULT_URL})",
    )
    p.add_argument("--api-key", default=None, help="API key (default $EVOMESH_API_KEY)")


def _mesh_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("mesh inputs (the service's defaults when left out)")
    g.add_argument("--size", type=float, help="target edge length (default: the h property)")
    g.add_argument("--growth", type=float)
    g.add_argument("--smooth", dest="method", help="smoothing method (see GET /processes/mesh)")
    g.add_argument("--no-swap", action="store_true", help="skip diagonal swapping")
    g.add_argument("--seed", type=int, help="random seed (default: the service picks one)")
    g.add_argument("--wgs84", action="store_true", help="coordinates are lon/lat")
    g.add_argument(
        "--input",
        dest="extra",
        action="append",
        default=[],
        metavar="NAME=JSON",
        help="any other input, e.g. --input smoothing.population=50 (repeatable)",
    )


def register(sub: Any) -> None:
    s = sub.add_parser(
        "submit",
        help="send a region to a service as a mesh job",
        description="Submit a mesh job for a region (GeoJSON or {outer, holes} JSON) and "
        "optionally wait for it and download its result.",
    )
    s.add_argument("region", help="GeoJSON or JSON file ('-' for standard input)")
    _connection_flags(s)
    s.add_argument("--wait", action="store_true", help="follow the job until it ends")
    s.add_argument(
        "-o",
        "--output",
        help="write the result here (implies --wait); the extension picks the format: "
        ".json .geojson .vtu .msh .svg .png",
    )
    _mesh_flags(s)
    s.set_defaults(handler=run_submit)

    b = sub.add_parser(
        "batch",
        help="mesh many regions on a service, one job each",
        description="Mesh every region of FILE_OR_DIR (each Feature of a FeatureCollection, "
        "each .geojson/.json file of a folder) as one batch, and write each result to OUTDIR.",
    )
    b.add_argument("source", metavar="FILE_OR_DIR")
    _connection_flags(b)
    b.add_argument("-o", "--output", required=True, metavar="OUTDIR", help="folder of results")
    b.add_argument(
        "--format",
        default="json",
        help="comma-separated result formats to write: json geojson vtu msh svg png",
    )
    _mesh_flags(b)
    b.set_defaults(handler=run_batch)

    j = sub.add_parser("jobs", help="list a service's jobs, newest first")
    _connection_flags(j)
    j.add_argument("--status", action="append", help="only this status (repeatable)")
    j.add_argument("--limit", type=int, default=20, help="how many (default 20)")
    j.set_defaults(handler=run_jobs)


# -- inputs ---------------------------------------------------------------------------------------


def _read_json(path: str) -> Any:
    try:
        text = sys.stdin.read() if path == "-" else Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ClientError(f"cannot read {path}: {exc.strerror or exc}", 2) from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ClientError(f"{path} is not JSON: {exc}", 2) from None


def _set(inputs: dict[str, Any], dotted: str, value: Any) -> None:
    *parents, name = dotted.split(".")
    for key in parents:
        inputs = inputs.setdefault(key, {})
    inputs[name] = value


def _shared_inputs(args: argparse.Namespace) -> dict[str, Any]:
    """The mesh inputs given by flags (those left out are the service's defaults)."""
    inputs: dict[str, Any] = {}
    for name in ("size", "growth"):
        if getattr(args, name) is not None:
            inputs[name] = getattr(args, name)
    if args.no_swap:
        inputs["swap"] = False
    if args.wgs84:
        inputs["coordinates"] = "wgs84"
    if args.method is not None:
        _set(inputs, "smoothing.method", args.method)
    if args.seed is not None:
        _set(inputs, "smoothing.seed", args.seed)
    for item in args.extra:
        name, sep, raw = item.partition("=")
        if not sep or not name:
            raise ClientError(f"--input wants NAME=JSON, got {item!r}", 2)
        try:
            value = json.loads(raw)
        except json.JSONDecodeError:
            value = raw  # a bare word: a string
        _set(inputs, name.strip(), value)
    return inputs


def _summary_line(doc: dict[str, Any]) -> str:
    s = doc.get("summary", {}).get("smoothed") or doc.get("summary", {}).get("mesh") or {}
    if not s:
        return f"{len(doc.get('triangles', [])):,} triangles"
    return (
        f"{s['count']:,} triangles, min quality {s['quality']['min']:.3f}, "
        f"min angle {s['min_angle']['min']:.1f} deg"
    )


# -- submit ---------------------------------------------------------------------------------------


def _follow(api: Api, job_id: str) -> dict[str, Any]:
    """Poll a job until it ends: a bar on a terminal, a line per stage otherwise."""
    if is_terminal():
        with make_progress(transient=True) as bar:
            task = bar.add_task(f"job {job_id[:8]}: queued", total=100)
            while True:
                status = api.job(job_id)
                bar.update(
                    task,
                    completed=status["progress"],
                    description=f"job {job_id[:8]}: {stage_label(_stage(status))}",
                )
                if status["status"] in FINAL:
                    return status
                time.sleep(POLL)
    last = None
    while True:
        status = api.job(job_id)
        stage = _stage(status)
        if stage != last and status["status"] not in FINAL:
            print(f"job {job_id}: {stage_label(stage)} {status['progress']}%", file=sys.stderr)
            last = stage
        if status["status"] in FINAL:
            return status
        time.sleep(POLL)


def _stage(status: dict[str, Any]) -> str:
    return "accepted" if status["status"] == "accepted" else str(status.get("message") or "")


def _finished(status: dict[str, Any]) -> None:
    if status["status"] != "successful":
        what = "was dismissed" if status["status"] == "dismissed" else "failed"
        reason = f": {status['message']}" if status.get("message") else ""
        raise ClientError(f"job {status['jobID']} {what}{reason}")


def run_submit(args: argparse.Namespace) -> int:
    fmt = format_for(args.output) if args.output else None  # a bad extension fails up front
    region = _read_json(args.region)
    inputs = {**_shared_inputs(args), "boundary": region}
    with Api(args.url, args.api_key) as api:
        status = api.execute("mesh", inputs)
        job_id = status["jobID"]
        if not (args.wait or args.output):
            print(job_id)
            return 0
        print(f"job {job_id} submitted to {api.url}", file=sys.stderr)
        try:
            status = _follow(api, job_id)
        except KeyboardInterrupt:
            print(f"\nthe job goes on; see: evomesh jobs --url {api.url}", file=sys.stderr)
            raise
        _finished(status)
        if args.output:
            assert fmt is not None
            data = api.result(job_id, fmt)
            Path(args.output).write_bytes(data)
            what = _summary_line(json.loads(data)) if fmt == "json" else f"{len(data):,} bytes"
            print(f"job {job_id}: {what} -> {args.output}")
        else:
            print(f"job {job_id}: successful")
    return 0


# -- batch ----------------------------------------------------------------------------------------


def _regions(source: Path) -> list[tuple[str, Any]]:
    """(name, region) of every region under ``source``: each Feature of a FeatureCollection,
    each other JSON document whole; named after their file (and the feature's name)."""
    if source.is_dir():
        files = sorted(p for p in source.iterdir() if p.suffix.lower() in (".geojson", ".json"))
        if not files:
            raise ClientError(f"no .geojson or .json files in {source}", 2)
    elif source.exists():
        files = [source]
    else:
        raise ClientError(f"{source} does not exist", 2)
    out: list[tuple[str, Any]] = []
    for path in files:
        doc = _read_json(str(path))
        if isinstance(doc, dict) and doc.get("type") == "FeatureCollection":
            for i, feature in enumerate(doc.get("features") or []):
                props = (feature or {}).get("properties") or {}
                name = props.get("name") or feature.get("id") or f"{path.stem}-{i + 1}"
                out.append((str(name), feature))
        else:
            out.append((path.stem, doc))
    names: dict[str, int] = {}
    unique = []
    for name, region in out:  # results must not overwrite each other
        safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "region"
        names[safe] = names.get(safe, 0) + 1
        unique.append((safe if names[safe] == 1 else f"{safe}-{names[safe]}", region))
    return unique


class _BatchView:
    """How a batch's progress is shown: an overall bar on a terminal, lines otherwise."""

    def __init__(self, total: int) -> None:
        self.total = total
        self.bar = make_progress() if is_terminal() else None
        self.task: Any = None
        self.last = ""

    def __enter__(self) -> _BatchView:
        if self.bar is not None:
            self.bar.start()
            self.task = self.bar.add_task("batch", total=self.total)
        return self

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.stop()

    def update(self, doc: dict[str, Any]) -> None:
        counts = doc["counts"]
        done = counts["successful"] + counts["failed"] + counts["dismissed"]
        text = f"{done}/{self.total} done, {counts['running']} running, {counts['failed']} failed"
        if self.bar is not None:
            # Each running job counts by its own progress, so the bar moves within long jobs.
            share = doc["progress"] / 100 * self.total
            self.bar.update(self.task, completed=share, description=f"batch: {text}")
        elif text != self.last:
            print(f"batch {doc['batchID']}: {text}", file=sys.stderr)
        self.last = text

    def say(self, line: str) -> None:
        if self.bar is not None:
            self.bar.console.print(line, highlight=False)
        else:
            print(line)


def run_batch(args: argparse.Namespace) -> int:
    formats = [f.strip() for f in args.format.split(",") if f.strip()]
    for f in formats:
        format_for(f"result.{f}")  # fails on an unknown format before anything is sent
    regions = _regions(Path(args.source))
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    body = {
        "process": "mesh",
        "inputs": _shared_inputs(args),
        "requests": [{"inputs": {"boundary": region}} for _, region in regions],
    }
    with Api(args.url, args.api_key) as api:
        batch = api.batch(body)
        names = {job["jobID"]: name for job, (name, _) in zip(batch["jobs"], regions, strict=True)}
        print(f"batch {batch['batchID']}: {len(regions)} jobs on {api.url}", file=sys.stderr)
        written: set[str] = set()
        failed: list[str] = []
        with _BatchView(len(regions)) as view:
            while True:
                doc = api.batch_status(batch["batchID"])
                view.update(doc)
                for job in doc["jobs"]:
                    job_id, status = job["jobID"], job["status"]
                    if status not in FINAL or job_id in written:
                        continue
                    written.add(job_id)
                    name = names[job_id]
                    if status == "successful":
                        view.say(_save(api, job_id, name, out, formats))
                    else:
                        failed.append(name)
                        view.say(f"{name}: {_why(api, job_id, status)}")
                if doc["status"] in FINAL and len(written) == len(regions):
                    break
                time.sleep(POLL * 2)
    ok = len(regions) - len(failed)
    print(f"{ok} of {len(regions)} regions meshed -> {out}", file=sys.stderr)
    if failed:
        raise ClientError(f"{len(failed)} failed: {', '.join(failed)}")
    return 0


def _save(api: Api, job_id: str, name: str, out: Path, formats: list[str]) -> str:
    paths, line = [], ""
    for f in formats:
        data = api.result(job_id, f)
        path = out / f"{name}.{f}"
        path.write_bytes(data)
        paths.append(path.name)
        if f == "json":
            line = _summary_line(json.loads(data))
    return f"{name}: {line + ' ' if line else ''}-> {', '.join(paths)}"


def _why(api: Api, job_id: str, status: str) -> str:
    message = api.job(job_id).get("message") or ""
    return f"{status}{': ' + message if message else ''}"


# -- jobs -----------------------------------------------------------------------------------------

_COLOURS = {"successful": "green", "failed": "red", "running": "cyan", "dismissed": "dim"}


def run_jobs(args: argparse.Namespace) -> int:
    params: dict[str, Any] = {"limit": args.limit}
    if args.status:
        params["status"] = args.status
    with Api(args.url, args.api_key) as api:
        doc = api.jobs(**params)
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
