"""``evomesh batch``: many regions meshed on a service as one batch, each result written to a
folder as soon as its job ends. On a terminal an overall bar, otherwise a line per change."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from ..client import FINAL, Batch, ClientError, Job
from ..formats import format_named
from .client import connect, connection_flags, mesh_flags, read_json, shared_inputs, summary_line
from .progress import is_terminal, make_progress

__all__ = ["register"]


def register(sub: Any) -> None:
    b = sub.add_parser(
        "batch",
        help="mesh many regions on a service, one job each",
        description="Mesh every region of FILE_OR_DIR (each Feature of a FeatureCollection, "
        "each .geojson/.json file of a folder) as one batch, and write each result to OUTDIR.",
    )
    b.add_argument("source", metavar="FILE_OR_DIR")
    connection_flags(b)
    b.add_argument("-o", "--output", required=True, metavar="OUTDIR", help="folder of results")
    b.add_argument(
        "--format",
        default="json",
        help="comma-separated result formats to write: json geojson vtu msh svg png",
    )
    mesh_flags(b)
    b.set_defaults(handler=run_batch)


def _regions(source: Path) -> list[tuple[str, Any]]:
    """(name, region) of every region under ``source``: each Feature of a FeatureCollection,
    each other JSON document whole; named after their file (and the feature's name)."""
    if source.is_dir():
        files = sorted(p for p in source.iterdir() if p.suffix.lower() in (".geojson", ".json"))
        if not files:
            raise ValueError(f"no .geojson or .json files in {source}")
    elif source.exists():
        files = [source]
    else:
        raise ValueError(f"{source} does not exist")
    out: list[tuple[str, Any]] = []
    for path in files:
        doc = read_json(str(path))
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


class _Writer:
    """Writes each job's results as it ends (from the batch's progress callback)."""

    def __init__(self, batch: Batch, names: list[str], out: Path, formats: list[str]) -> None:
        self.jobs = {job.id: (job, name) for job, name in zip(batch.jobs, names, strict=True)}
        self.out = out
        self.formats = formats
        self.written: set[str] = set()
        self.failed: list[str] = []

    def __call__(self, doc: dict[str, Any], view: _BatchView) -> None:
        view.update(doc)
        for item in doc["jobs"]:
            job_id, status = item["jobID"], item["status"]
            if status not in FINAL or job_id in self.written:
                continue
            self.written.add(job_id)
            job, name = self.jobs[job_id]
            if status == "successful":
                view.say(self._save(job, name))
            else:
                self.failed.append(name)
                message = job.status().message
                view.say(f"{name}: {status}{': ' + message if message else ''}")

    def _save(self, job: Job, name: str) -> str:
        paths, line = [], ""
        for f in self.formats:
            path = self.out / f"{name}.{f}"
            data = job.result(f, path=path)
            paths.append(path.name)
            if f == "json":
                line = summary_line(json.loads(data))
        return f"{name}: {line + ' ' if line else ''}-> {', '.join(paths)}"


def run_batch(args: argparse.Namespace) -> int:
    formats = [f.strip() for f in args.format.split(",") if f.strip()]
    for f in formats:
        format_named(f)  # fails on an unknown format before anything is sent
    regions = _regions(Path(args.source))
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    with connect(args) as client:
        batch = client.batch([{"boundary": r} for _, r in regions], **shared_inputs(args))
        print(f"batch {batch.id}: {len(regions)} jobs on {client.url}", file=sys.stderr)
        writer = _Writer(batch, [name for name, _ in regions], out, formats)
        with _BatchView(len(regions)) as view:
            batch.wait(progress=lambda doc: writer(doc, view))
    ok = len(regions) - len(writer.failed)
    print(f"{ok} of {len(regions)} regions meshed -> {out}", file=sys.stderr)
    if writer.failed:
        raise ClientError(f"{len(writer.failed)} failed: {', '.join(writer.failed)}")
    return 0
