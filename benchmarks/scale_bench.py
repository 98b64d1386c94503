"""Scale-out benchmark: the local pool against Dask with 1 and 2 workers, on this machine.

Everything runs as deployed, as separate processes on 127.0.0.1: ``evomesh serve`` (``--workers
N``, or ``--backend dask --scheduler``), ``dask scheduler`` and single-threaded ``dask worker``
processes. Three parts, bounded in count and time; prints, asserts nothing.

1. **Per-job overhead**: the same batch of 1,000 small ``mesh`` jobs (about 500 triangles, smoothing
   ``none``), posted as one ``/batches`` request and polled until every job ended. Jobs per
   second, and Dask's overhead per job: the difference in wall time per job against the local pool
   with the same number of workers, with the CPU time per job of each process.
2. **Scaling**: a batch of jobs of about 1 s each (the size is calibrated here first) on 1 and 2
   workers; the speed-up from 1 to 2.
3. **Large results**: a 66 MB result (the size of the compressed document of a 1,000,000-triangle
   mesh) fetched by the service through the scheduler, straight from the worker, or written by
   the worker to a file the service reads, with the scheduler's responsiveness meanwhile.

    python benchmarks/scale_bench.py [--jobs 1000] [--slow-jobs 8]

Each part writes its figures to ``benchmarks/results/scale_<part>.json`` (``record.py``).
"""

from __future__ import annotations

import argparse
import asyncio
import math
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from record import write_rows  # noqa: E402 - benchmarks/ is on the path as the script's folder

from tests.e2e.dask_cluster import DaskCluster  # noqa: E402 - after the path set-up
from tests.e2e.server import Server, descendants  # noqa: E402

SQUARE = {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]}
#: About 500 triangles (the service benchmark's job): area / (sqrt(3)/4 * size^2).
SMALL = math.sqrt(1.0 / (500 * math.sqrt(3) / 4))
#: The compressed mesh document of the unit square at size 0.00152: 1,001,834 triangles.
LARGE_BYTES = 65_966_630
FINAL = {"successful", "failed", "dismissed"}


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process and its descendants so far, from /proc."""
    total = 0.0
    for p in [pid, *descendants(pid)]:
        try:
            fields = Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return total


@contextmanager
def service(folder: Path, workers: int, dask: bool) -> Iterator[tuple[Server, DaskCluster | None]]:
    """A server on the local pool (``workers`` processes) or on a fresh Dask cluster."""
    cluster = DaskCluster(folder / "dask", workers=workers) if dask else None
    env = {"EVOMESH_BACKEND": "dask", "EVOMESH_SCHEDULER": cluster.address} if cluster else {}
    server = None
    try:
        server = Server(folder / "data", workers=workers, **env)
        yield server, cluster
    finally:
        if server is not None:
            server.stop()
        if cluster is not None:
            cluster.stop()


def run_batch(server: Server, size: float, count: int, seed0: int) -> tuple[float, list[str]]:
    """Post ``count`` mesh jobs as one batch; seconds until every one ended, and the job ids."""
    requests = [
        {"inputs": {"smoothing": {"method": "none", "seed": seed0 + i}}} for i in range(count)
    ]
    body = {"process": "mesh", "inputs": {"boundary": SQUARE, "size": size}, "requests": requests}
    t0 = time.perf_counter()
    r = server.client.post("/batches", json=body, timeout=120)
    assert r.status_code == 201, r.text
    batch = r.json()
    while True:
        doc = server.client.get(f"/batches/{batch['batchID']}", timeout=60).json()
        if all(job["status"] in FINAL for job in doc["jobs"]):
            break
        time.sleep(0.1)
    seconds = time.perf_counter() - t0
    failed = [j for j in doc["jobs"] if j["status"] != "successful"]
    assert not failed, failed[:3]
    return seconds, [j["jobID"] for j in doc["jobs"]]


def processes(server: Server, cluster: DaskCluster | None) -> dict[str, int]:
    pids = {"service": server.proc.pid}
    if cluster is not None:
        assert cluster.scheduler is not None
        pids["scheduler"] = cluster.scheduler.pid
        for i, worker in enumerate(cluster.workers):
            pids[f"worker {i}"] = worker.pid
    return pids


def overhead(folder: Path, jobs: int) -> dict[tuple[str, int], float]:
    print(f"== 1. per-job overhead: one batch of {jobs} mesh jobs (~500 triangles)")
    print(f"{'backend':<8} {'workers':>7} {'seconds':>8} {'jobs/s':>8}  CPU ms per job")
    wall: dict[tuple[str, int], float] = {}
    rows: list[dict[str, object]] = []
    for workers in (1, 2):  # each pair back to back: the machine's other load drifts
        for dask in (False, True):
            name = "dask" if dask else "local"
            with service(folder / f"o-{name}-{workers}", workers, dask) as (server, cluster):
                run_batch(server, SMALL, 4 * workers, 0)  # every worker warm
                pids = processes(server, cluster)
                before = {k: cpu_seconds(p) for k, p in pids.items()}
                seconds, _ = run_batch(server, SMALL, jobs, 1000)
                cpu = {k: (cpu_seconds(p) - before[k]) * 1000 / jobs for k, p in pids.items()}
            wall[name, workers] = seconds
            shares = ", ".join(f"{k} {v:.1f}" for k, v in cpu.items())
            print(f"{name:<8} {workers:>7} {seconds:>8.2f} {jobs / seconds:>8.1f}  {shares}")
            rows.append(
                {
                    "backend": name,
                    "workers": workers,
                    "s": round(seconds, 2),
                    "jobs/s": round(jobs / seconds, 1),
                    "CPU ms per job": shares,
                }
            )
    for workers in (1, 2):
        extra = (wall["dask", workers] - wall["local", workers]) * 1000 / jobs
        ratio = wall["local", workers] / wall["dask", workers]
        print(
            f"Dask overhead with {workers} worker(s): {extra:+.1f} ms per job "
            f"(Dask runs at {ratio:.2f}x the local pool's rate)"
        )
        for row in rows:
            if row["backend"] == "dask" and row["workers"] == workers:
                row["Dask overhead ms per job"] = round(extra, 1)
    write_rows(
        "scale_overhead",
        rows,
        title="Scale-out: per-job overhead, local pool and Dask (benchmarks/scale_bench.py)",
        notes=f"One /batches request of {jobs} mesh jobs (about 500 triangles, smoothing none), "
        "polled until every job ended; Dask's overhead is the wall time per job against the "
        f"local pool with as many workers. {_load()}",
    )
    return wall


def calibrate(target: float) -> float:
    """The unit-square size whose ``mesh`` job takes about ``target`` seconds here (the job's
    time grows with its triangles, about 1 / size^2)."""
    import engine
    from service import processes
    from service.processes import PROCESSES, inputs_at
    from service.settings import Settings

    engine.warmup()
    mesh = PROCESSES["mesh"]
    settings = Settings(_env_file=None)  # type: ignore[call-arg]
    size = 0.008
    for _ in range(3):
        inputs = {"boundary": SQUARE, "size": size, "growth": 1.2, "swap": True}
        model = mesh.inputs_model.model_validate({**inputs, "smoothing": {"method": "none"}})
        # the payload a job runs with: the request as the service prepares it
        prepared = mesh.prepare(model, settings, inputs_at("/inputs"))
        t0 = time.perf_counter()
        processes.run("mesh", prepared.inputs, _quiet, _never)
        size *= math.sqrt((time.perf_counter() - t0) / target)
    return round(size, 5)


def _quiet(percent: int, message: str) -> None:
    pass


def _never() -> bool:
    return False


def scaling(folder: Path, jobs: int) -> None:
    size = calibrate(1.2)
    print(f"== 2. scaling: one batch of {jobs} jobs of about 1 s (unit square, size {size})")
    print(f"{'backend':<8} {'workers':>7} {'seconds':>8} {'jobs/s':>8}  mean run s")
    rate: dict[tuple[str, int], float] = {}
    rows: list[dict[str, object]] = []
    for workers in (1, 2):
        for dask in (False, True):
            name = "dask" if dask else "local"
            with service(folder / f"s-{name}-{workers}", workers, dask) as (server, _):
                run_batch(server, SMALL, 2 * workers, 0)
                seconds, ids = run_batch(server, size, jobs, 5000)
                run_s = statistics.mean(run_seconds(server, i) for i in ids)
            rate[name, workers] = jobs / seconds
            print(f"{name:<8} {workers:>7} {seconds:>8.2f} {jobs / seconds:>8.2f}  {run_s:.2f}")
            rows.append(
                {
                    "backend": name,
                    "workers": workers,
                    "s": round(seconds, 2),
                    "jobs/s": round(jobs / seconds, 2),
                    "mean run s": round(run_s, 2),
                }
            )
    for name in ("local", "dask"):
        speedup = rate[name, 2] / rate[name, 1]
        print(f"{name}: 1 -> 2 workers: {speedup:.2f}x (2.00x is linear)")
        rows[-1 if name == "dask" else -2]["speed-up 1 -> 2 workers"] = round(speedup, 2)
    write_rows(
        "scale_scaling",
        rows,
        title="Scale-out: scaling from 1 to 2 workers (benchmarks/scale_bench.py)",
        notes=f"One batch of {jobs} mesh jobs of about 1 s each (unit square at size {size}); "
        f"2.00x from 1 to 2 workers is linear. {_load()}",
    )


def run_seconds(server: Server, job_id: str) -> float:
    """A job's run time as the service saw it: from started to finished."""
    doc = server.client.get(f"/jobs/{job_id}", timeout=60).json()
    started, finished = (datetime.fromisoformat(doc[k]) for k in ("started", "finished"))
    return (finished - started).total_seconds()


def _large(nbytes: int) -> bytes:
    return os.urandom(nbytes)  # incompressible, like a zlib-compressed document


async def _large_results(address: str, folder: Path, rounds: int) -> None:
    from distributed import Client, as_completed

    async with Client(address, asynchronous=True, set_as_default=False) as client:
        assert client.scheduler is not None
        scheduler = client.scheduler

        async def ping(stop: asyncio.Event, out: list[float]) -> None:
            while not stop.is_set():
                t0 = time.perf_counter()
                await scheduler.identity(n_workers=0)
                out.append(time.perf_counter() - t0)
                await asyncio.sleep(0.005)

        print(f"{'path':<28} {'median ms':>9} {'min ms':>7}  scheduler ping p50 / max ms")
        rows: list[dict[str, object]] = []
        for how in ("through the scheduler", "straight from the worker", "worker writes a file"):
            times: list[float] = []
            pings: list[float] = []
            for i in range(rounds):
                path = str(folder / f"large-{i}.bin")
                stop = asyncio.Event()
                pinger = asyncio.create_task(ping(stop, pings))
                if how == "worker writes a file":
                    write = await client.submit(_timed_write, LARGE_BYTES, path, pure=False)
                    t0 = time.perf_counter()
                    data = await asyncio.to_thread(Path(path).read_bytes)
                    elapsed = time.perf_counter() - t0 + write
                else:
                    future = client.submit(_large, LARGE_BYTES, pure=False)
                    async for _ in as_completed([future], loop=client.loop):
                        pass  # the result is in the worker's memory
                    t0 = time.perf_counter()
                    data = await client.gather(future, direct=how == "straight from the worker")
                    elapsed = time.perf_counter() - t0
                    del future
                stop.set()
                await pinger
                assert len(data) == LARGE_BYTES
                times.append(elapsed)
                del data
                Path(path).unlink(missing_ok=True)
            print(
                f"{how:<28} {statistics.median(times) * 1000:>9.0f} {min(times) * 1000:>7.0f}  "
                f"{statistics.median(pings) * 1000:.1f} / {max(pings) * 1000:.0f}"
            )
            rows.append(
                {
                    "path": how,
                    "median ms": round(statistics.median(times) * 1000),
                    "min ms": round(min(times) * 1000),
                    "scheduler ping p50 ms": round(statistics.median(pings) * 1000, 1),
                    "scheduler ping max ms": round(max(pings) * 1000),
                }
            )
    write_rows(
        "scale_large",
        rows,
        title="Scale-out: large results from a Dask worker (benchmarks/scale_bench.py)",
        notes=f"A {LARGE_BYTES / 1e6:.0f} MB result (the compressed document of a "
        f"1,001,834-triangle mesh), {rounds} rounds per path, with the scheduler's ping time "
        f"meanwhile. {_load()}",
    )


def _load() -> str:
    return f"Load average (1 min) when the part ended: {os.getloadavg()[0]:.1f}."


def _timed_write(nbytes: int, path: str) -> float:
    """Write a result as the file path would; the seconds the write took."""
    data = os.urandom(nbytes)
    t0 = time.perf_counter()
    with open(f"{path}.tmp", "wb") as f:
        f.write(data)
    os.replace(f"{path}.tmp", path)
    return time.perf_counter() - t0


def large_results(folder: Path, rounds: int) -> None:
    print(f"== 3. large results: {LARGE_BYTES / 1e6:.0f} MB from one worker, {rounds} rounds")
    cluster = DaskCluster(folder / "large", workers=1)
    try:
        asyncio.run(_large_results(cluster.address, folder, rounds))
    finally:
        cluster.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=1000, help="jobs of the overhead batch")
    parser.add_argument("--slow-jobs", type=int, default=8, help="jobs of the scaling batch")
    parser.add_argument("--rounds", type=int, default=5, help="large-result transfers per path")
    parser.add_argument(
        "--parts", default="overhead,scaling,large", help="comma-separated parts to run"
    )
    args = parser.parse_args()
    parts = set(args.parts.split(","))
    print(f"CPUs: {os.cpu_count()}, load average at start: {os.getloadavg()}")
    with tempfile.TemporaryDirectory(prefix="scale-bench-") as tmp:
        folder = Path(tmp)
        if "overhead" in parts:
            overhead(folder, args.jobs)
        if "scaling" in parts:
            scaling(folder, args.slow_jobs)
        if "large" in parts:
            large_results(folder, args.rounds)
    print(f"load average at the end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
