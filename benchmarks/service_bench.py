"""Service benchmark: many clients submitting small jobs to a real server on loopback.

50 concurrent clients submit 1,000 small ``mesh`` jobs (about 500 triangles each by the area
estimate, smoothing ``none``) and poll each until it ends. Prints jobs per second, the p50/p99
latency of ``GET /jobs/{id}`` while the workers are busy (timed by a separate light process
probing every 10 ms, and as the load clients saw it), lost jobs (submitted but not successful with
a result) and CPU time per job. Bounded in count and time; traffic only to 127.0.0.1. Prints,
does not assert.

    python benchmarks/service_bench.py [--jobs 1000] [--clients 50] [--workers N]
"""

from __future__ import annotations

import argparse
import asyncio
import math
import multiprocessing
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from record import write_rows  # noqa: E402 - benchmarks/ is on the path as the script's folder

from tests.e2e.server import Server, descendants  # noqa: E402 - after the path set-up

#: A unit square at this size is about 500 triangles: area / (sqrt(3)/4 * size^2).
SIZE = math.sqrt(1.0 / (500 * math.sqrt(3) / 4))
SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
FINAL = {"successful", "failed", "dismissed"}
RETRY = (httpx.ReadError, httpx.RemoteProtocolError, httpx.ConnectError)


def body(seed: int | None = None) -> dict[str, Any]:
    smoothing: dict[str, Any] = {"method": "none"}
    if seed is not None:
        smoothing["seed"] = seed
    return {"inputs": {"boundary": SQUARE, "size": SIZE, "smoothing": smoothing}}


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far, from /proc."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def p50_p99_ms(values: list[float]) -> tuple[float | None, float | None]:
    if len(values) < 2:
        return None, None
    q = statistics.quantiles(values, n=100)
    return round(q[49] * 1000, 1), round(q[98] * 1000, 1)


def quantiles(values: list[float]) -> str:
    if len(values) < 2:
        return "n/a"
    q = statistics.quantiles(values, n=100)
    return (
        f"n={len(values)}  p50 {q[49] * 1000:.1f} ms  p99 {q[98] * 1000:.1f} ms  "
        f"max {max(values) * 1000:.1f} ms"
    )


async def request(http: httpx.AsyncClient, method: str, url: str, **kw: Any) -> httpx.Response:
    """A request, retried when a kept-alive connection was closed under it (POSTs carry an
    Idempotency-Key, so a retry never makes a second job)."""
    for attempt in range(5):
        try:
            return await http.request(method, url, **kw)
        except RETRY:
            if attempt == 4:
                raise
            await asyncio.sleep(0.05)
    raise AssertionError("unreachable")


def probe(host: str, port: int, path: str, interval: float, stop: Any, out: Any) -> None:
    """Time ``GET path`` every ``interval`` seconds until ``stop`` is set: a separate, light
    process, so the load generator's own busy event loop does not inflate the figures."""
    import http.client

    conn = http.client.HTTPConnection(host, port, timeout=30)
    latencies = []
    while not stop.is_set():
        t0 = time.perf_counter()
        conn.request("GET", path)
        conn.getresponse().read()
        latencies.append(time.perf_counter() - t0)
        time.sleep(interval)
    out.send(latencies)


class Load:
    """What the load clients did."""

    def __init__(self) -> None:
        self.latencies: list[float] = []
        self.submitted: list[str] = []
        self.ended: dict[str, str] = {}


async def client_loop(
    http: httpx.AsyncClient, todo: asyncio.Queue[int], poll: float, deadline: float, load: Load
) -> None:
    while not todo.empty() and time.monotonic() < deadline:
        i = todo.get_nowait()
        headers = {"Idempotency-Key": f"bench-{i}"}
        r = await request(http, "POST", "/processes/mesh/execution", json=body(i), headers=headers)
        if r.status_code != 201:
            print(f"submit {i}: {r.status_code} {r.text[:200]}", file=sys.stderr)
            continue
        job_id = r.json()["jobID"]
        load.submitted.append(job_id)
        while time.monotonic() < deadline:
            await asyncio.sleep(poll)
            t0 = time.perf_counter()
            r = await request(http, "GET", f"/jobs/{job_id}")
            load.latencies.append(time.perf_counter() - t0)
            if r.json()["status"] in FINAL:
                load.ended[job_id] = r.json()["status"]
                break


async def run(args: argparse.Namespace, url: str, server_pid: int, workers: int) -> None:
    load_before = os.getloadavg()[0]
    todo: asyncio.Queue[int] = asyncio.Queue()
    for i in range(args.jobs):
        todo.put_nowait(i)
    load = Load()
    limits = httpx.Limits(max_connections=args.clients, max_keepalive_connections=args.clients)
    async with httpx.AsyncClient(base_url=url, limits=limits, timeout=60) as http:
        first = (await request(http, "POST", "/processes/mesh/execution", json=body())).json()
        ctx = multiprocessing.get_context("spawn")
        stop = ctx.Event()
        receiver, sender = ctx.Pipe(duplex=False)
        host, port = url.removeprefix("http://").split(":")
        path = f"/jobs/{first['jobID']}"
        prober = ctx.Process(target=probe, args=(host, int(port), path, 0.01, stop, sender))
        prober.start()
        procs = [server_pid, *descendants(server_pid)]
        cpu0 = {p: cpu_seconds(p) for p in procs}
        mine0 = cpu_seconds(os.getpid())
        t0 = time.perf_counter()
        deadline = time.monotonic() + args.budget
        await asyncio.gather(
            *(client_loop(http, todo, args.poll, deadline, load) for _ in range(args.clients))
        )
        wall = time.perf_counter() - t0
        stop.set()
        probed: list[float] = receiver.recv()
        prober.join()
        used = {p: cpu_seconds(p) - cpu0[p] for p in procs}
        server_cpu = used.pop(server_pid)
        worker_cpu = sum(used.values())
        client_cpu = cpu_seconds(os.getpid()) - mine0
        # Lost: submitted but not successful, or successful without a result.
        lost = [j for j in load.submitted if load.ended.get(j) != "successful"]
        sem = asyncio.Semaphore(args.clients)

        async def has_result(job_id: str) -> bool:
            async with sem:
                r = await request(http, "GET", f"/jobs/{job_id}/results")
                return r.status_code == 200 and bool(r.json()["triangles"])

        ok = await asyncio.gather(*(has_result(j) for j in load.submitted if j not in lost))
        listed = (await http.get("/jobs", params={"limit": 1})).json()["numberMatched"]
        doc = (await http.get(f"/jobs/{first['jobID']}/results")).json()
    done = max(1, len(load.ended))
    print(f"jobs submitted       {len(load.submitted)} of {args.jobs} ({args.clients} clients)")
    print(f"triangles per job    {len(doc['triangles'])}")
    print(f"wall time            {wall:.2f} s")
    print(f"throughput           {len(load.ended) / wall:.1f} jobs/s")
    print(f"GET /jobs/{{id}}       {quantiles(probed)}  (probe every 10 ms)")
    print(
        f"  as clients saw it  {quantiles(load.latencies)}  (poll every {args.poll * 1000:.0f} ms)"
    )
    missing = ok.count(False)
    print(f"lost jobs            {len(lost) + missing} (failed {len(lost)}, no result {missing})")
    print(f"jobs in /jobs        {listed} (1 probe job + {listed - 1})")
    server_ms, worker_ms = 1000 * server_cpu / done, 1000 * worker_cpu / done
    client_ms = 1000 * client_cpu / done
    print(
        f"CPU per job          server {server_ms:.1f} ms, workers {worker_ms:.1f} ms, "
        f"load clients {client_ms:.1f} ms"
    )
    probe_p50, probe_p99 = p50_p99_ms(probed)
    seen_p50, seen_p99 = p50_p99_ms(load.latencies)
    figures: list[tuple[str, object]] = [
        ("jobs submitted", len(load.submitted)),
        ("load clients", args.clients),
        ("workers", workers),
        ("triangles per job", len(doc["triangles"])),
        ("wall time (s)", round(wall, 2)),
        ("throughput (jobs/s)", round(len(load.ended) / wall, 1)),
        ("lost jobs", len(lost) + missing),
        ("GET /jobs/{id} p50, probe (ms)", probe_p50),
        ("GET /jobs/{id} p99, probe (ms)", probe_p99),
        ("GET /jobs/{id} p50, as load clients saw it (ms)", seen_p50),
        ("GET /jobs/{id} p99, as load clients saw it (ms)", seen_p99),
        ("CPU per job, server (ms)", round(server_ms, 1)),
        ("CPU per job, workers (ms)", round(worker_ms, 1)),
        ("CPU per job, load clients (ms)", round(client_ms, 1)),
    ]
    path = write_rows(
        "service",
        [{"figure": name, "value": value} for name, value in figures],
        title="Service: many clients, small jobs (benchmarks/service_bench.py)",
        notes=f"A real evomesh serve on loopback; {args.clients} concurrent clients submit "
        f"{args.jobs} mesh jobs (unit square, smoothing none) and poll each every "
        f"{args.poll * 1000:.0f} ms; GET /jobs/{{id}} latency timed by a separate probe every "
        "10 ms while the workers are busy. Load average (1 min) at the start: "
        f"{load_before:.1f}.",
    )
    print(f"figures written to   {path.relative_to(ROOT)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--jobs", type=int, default=1000)
    parser.add_argument("--clients", type=int, default=50)
    parser.add_argument("--workers", type=int, default=None, help="default: the server's (CPUs)")
    parser.add_argument("--poll", type=float, default=0.1, help="seconds between status polls")
    parser.add_argument("--budget", type=float, default=300.0, help="seconds at most")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        server = Server(Path(tmp) / "data", workers=args.workers, EVOMESH_LOG_LEVEL="warning")
        try:
            ready = server.client.get("/ready").json()
            print(f"server               {server.url}, {ready['workers']['alive']} workers")
            asyncio.run(run(args, server.url, server.proc.pid, ready["workers"]["alive"]))
        finally:
            server.stop()


if __name__ == "__main__":
    main()
