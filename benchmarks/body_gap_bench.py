"""Event-loop stall benchmark: how long ``/health`` goes unanswered while a large body is read.

A real server on loopback is sent a ~25 MB ``quality`` request (a 600 x 600 grid mesh) while a
second client asks ``/health`` back to back: refused by validation, refused by admission (an
inverted triangle: read and checked after validation, in the body pool since issue 13's missed
item), and accepted (its inputs encoded in the pool, written to the store in a thread and handed
to the worker as those bytes: before, the API process unpickled them, encoded them on the event
loop and pickled them again for the worker); then a ``/batches`` body of about the same size
(``--members`` quality requests) refused by one item's admission, and accepted (admitted whole in
the pool since issue 13's leftovers; before, a batch went the thread path whatever its size, its
rows encoded on the event loop). Prints, for the body read in a thread
(``EVOMESH_BODY_WORKERS=0``, the old way) and in the body process pool, the longest gap
between two ``/health`` answers while the POST was in flight and how many answers came. Traffic
only to 127.0.0.1. Prints, does not assert.

    python benchmarks/body_gap_bench.py [--side 600] [--repeat 2] [--members 20]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import httpx
import orjson

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from record import write_rows  # noqa: E402 - benchmarks/ is on the path as the script's folder

from tests.e2e.server import Server  # noqa: E402 - after the path set-up
from tests.service.test_body_pool import grid_mesh  # noqa: E402 - the tests' grid mesh


def grid_body(side: int, refused: bool = False, inverted: bool = False) -> bytes:
    """A ``quality`` request for a side x side grid of points with non-round coordinates;
    ``refused``: its last triangle index a string, so validation walks it all, then says 422;
    ``inverted``: its last triangle turned over, so it passes validation and admission (the
    mesh read and checked) refuses it with 422."""
    mesh = grid_mesh(side)
    triangles = mesh["triangles"]
    if refused:
        triangles[-1][2] = "7"
    if inverted:
        triangles[-1][1], triangles[-1][2] = triangles[-1][2], triangles[-1][1]
    return orjson.dumps({"inputs": {"mesh": mesh}})


def batch_body(side: int, members: int, inverted: bool = False) -> bytes:
    """A ``/batches`` request of ``members`` quality requests of about the same total size as
    one ``side`` x ``side`` grid (``inverted``: the last member's last triangle turned over, so
    admission refuses the whole batch with 422)."""
    each = max(3, round(side / members**0.5))
    requests = [{"inputs": {"mesh": grid_mesh(each)}} for _ in range(members)]
    if inverted:
        last = requests[-1]["inputs"]["mesh"]["triangles"][-1]
        last[1], last[2] = last[2], last[1]
    return orjson.dumps({"process": "quality", "requests": requests})


def settle(response: httpx.Response) -> None:
    """Wait until an accepted job (or batch) has ended, so that its run does not load the next
    measurement."""
    if response.status_code != 201:
        return
    with httpx.Client(timeout=60) as c:
        while c.get(response.headers["Location"]).json()["status"] in ("accepted", "running"):
            time.sleep(0.2)


def measure(server: Server, path: str, body: bytes) -> dict[str, Any]:
    """The longest gap between ``/health`` answers while ``body`` is posted to ``path``, and
    their count."""
    answers: list[float] = []
    stop = threading.Event()

    def probe() -> None:
        with httpx.Client(base_url=server.url, timeout=60) as c:
            while not stop.is_set():
                c.get("/health").raise_for_status()
                answers.append(time.perf_counter())

    thread = threading.Thread(target=probe)
    thread.start()
    time.sleep(0.5)  # the probe is answering before the body goes
    start = time.perf_counter()
    with httpx.Client(base_url=server.url, timeout=120) as c:
        r = c.post(
            path,
            content=body,
            headers={"Content-Type": "application/json"},
        )
    end = time.perf_counter()
    stop.set()
    thread.join()
    settle(r)
    during = [t for t in answers if start <= t <= end]
    marks = [start, *during, end]
    gap = max(b - a for a, b in itertools.pairwise(marks))
    return {"status": r.status_code, "post_s": end - start, "gap_s": gap, "answers": len(during)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", type=int, default=600)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--members", type=int, default=20, help="requests of the batch bodies")
    args = parser.parse_args()
    one, batches = "/processes/quality/execution", "/batches"
    bodies = {
        "refused (422)": (one, grid_body(args.side, True)),
        "admission 422": (one, grid_body(args.side, inverted=True)),
        "accepted (201)": (one, grid_body(args.side)),
        "batch admission 422": (batches, batch_body(args.side, args.members, inverted=True)),
        "batch accepted (201)": (batches, batch_body(args.side, args.members)),
    }
    for kind, (_, body) in bodies.items():
        print(f"{kind}: {len(body) / 1e6:.1f} MB")
    rows: list[dict[str, Any]] = []
    for label, workers in (("thread (before)", "0"), ("process pool (after)", "2")):
        with tempfile.TemporaryDirectory() as tmp:
            server = Server(Path(tmp), workers=1, EVOMESH_BODY_WORKERS=workers)
            try:
                time.sleep(3)  # the pool's processes have imported the service
                for kind, (path, body) in bodies.items():
                    for _ in range(args.repeat):
                        m = measure(server, path, body)
                        print(
                            f"{label:21s} {kind:20s} POST {m['post_s']:5.2f} s  longest /health"
                            f" gap {m['gap_s']:.3f} s  answers during POST {m['answers']}"
                        )
                        row = {"body reading": label, "request": kind}
                        rows.append({**row, "MB": round(len(body) / 1e6, 1), **m})
            finally:
                server.stop()
    for kind in bodies:
        gaps = {
            label: min(
                r["gap_s"] for r in rows if r["body reading"] == label and r["request"] == kind
            )
            for label in ("thread (before)", "process pool (after)")
        }
        before, after = gaps.values()
        print(f"{kind}: longest gap, best of {args.repeat}: {before:.3f} s -> {after:.3f} s")
    write_rows(
        "body_gap",
        [{k: round(v, 3) if isinstance(v, float) else v for k, v in r.items()} for r in rows],
        title="Longest /health gap while a large body is read",
        notes="benchmarks/body_gap_bench.py: a real server on loopback, /health asked back to"
        " back while a quality request of the given size is posted",
    )


if __name__ == "__main__":
    main()
