"""A bounded load on a real server: concurrent clients submit jobs, one by one and in batches
(honouring 429 Retry-After), and poll them to the end, while a probe thread times status
requests throughout."""

from __future__ import annotations

import asyncio
import statistics
import threading
import time
import uuid
from dataclasses import dataclass, field
from typing import Any

import httpx

FINAL = {"successful", "failed", "dismissed"}


@dataclass
class LoadReport:
    jobs: int  #: asked for
    accepted: int = 0  #: distinct jobs the clients were given (201)
    final: int = 0  #: accepted jobs seen in a final state
    successful: int = 0
    lost: int = 0  #: accepted jobs missing from the store, or not final by the deadline
    refused: int = 0  #: 429s (each retried after its Retry-After)
    transport_errors: int = 0  #: load requests retried after a broken connection
    stored: int = 0  #: jobs the store holds at the end
    status_requests: int = 0  #: the probe's
    status_errors: int = 0  #: probe requests that failed or were not 200
    status_p50: float = 0.0  #: seconds
    status_p99: float = 0.0
    status_max: float = 0.0
    seconds: float = 0.0
    latencies: list[float] = field(default_factory=list, repr=False)


class _Probe(threading.Thread):
    """``GET /jobs/{id}`` every 20 ms from a thread of its own (the load's event loop is busy)."""

    def __init__(self, base: str, report: LoadReport) -> None:
        super().__init__(name="status-probe", daemon=True)
        self.base = base
        self.report = report
        self.job_id: str | None = None
        self.stop = threading.Event()

    def run(self) -> None:
        with httpx.Client(base_url=self.base, timeout=30) as http:
            while not self.stop.wait(0.02):
                if self.job_id is None:
                    continue
                t0 = time.perf_counter()
                try:
                    ok = http.get(f"/jobs/{self.job_id}").status_code == 200
                except httpx.HTTPError:
                    ok = False
                self.report.latencies.append(time.perf_counter() - t0)
                self.report.status_requests += 1
                self.report.status_errors += not ok


async def _post(
    http: httpx.AsyncClient,
    path: str,
    body: dict[str, Any],
    report: LoadReport,
    deadline: float,
    key: str | None = None,
) -> dict[str, Any]:
    """POST until accepted, sleeping each 429's Retry-After; with an idempotency ``key`` a
    broken connection is retried too (the job cannot be created twice)."""
    headers = {"Idempotency-Key": key} if key else {}
    while True:
        assert time.monotonic() < deadline, "submissions did not finish in time"
        try:
            r = await http.post(path, json=body, headers=headers)
        except httpx.TransportError:
            if key is None:
                raise
            report.transport_errors += 1
            continue
        if r.status_code == 201:
            doc: dict[str, Any] = r.json()
            return doc
        assert r.status_code == 429, r.text
        report.refused += 1
        await asyncio.sleep(float(r.headers["retry-after"]))


async def _until_final(
    http: httpx.AsyncClient, urls: list[str], report: LoadReport, deadline: float
) -> None:
    """Poll the oldest unfinished job or batch once a second: jobs end roughly in order, so
    this stays light."""
    pending = list(urls)
    while pending and time.monotonic() < deadline:
        try:
            doc = (await http.get(pending[0])).json()
        except httpx.TransportError:
            report.transport_errors += 1
            continue
        jobs = doc.get("jobs", [doc])
        if all(job.get("status") in FINAL for job in jobs):
            pending.pop(0)
        else:
            await asyncio.sleep(1.0)


async def _one_client(
    http: httpx.AsyncClient,
    count: int,
    batch: int,
    inputs: dict[str, Any],
    report: LoadReport,
    probe: _Probe,
    deadline: float,
) -> list[str]:
    """``count`` jobs: half one execution each, the rest in batches of ``batch``."""
    ids: list[str] = []
    urls: list[str] = []
    singles = count // 2
    for _ in range(singles):
        path = "/processes/mesh/execution"
        job = await _post(http, path, {"inputs": inputs}, report, deadline, uuid.uuid4().hex)
        ids.append(job["jobID"])
        urls.append(f"/jobs/{job['jobID']}")
        probe.job_id = probe.job_id or job["jobID"]
    left = count - singles
    while left:
        n = min(batch, left)
        body = {"process": "mesh", "inputs": inputs, "requests": [{}] * n}
        doc = await _post(http, "/batches", body, report, deadline)
        ids += [job["jobID"] for job in doc["jobs"]]
        urls.append(f"/batches/{doc['batchID']}")
        left -= n
    await _until_final(http, urls, report, deadline)
    return ids


async def _statuses(http: httpx.AsyncClient) -> dict[str, str]:
    """Every job in the store and its status, a thousand a page."""
    out: dict[str, str] = {}
    offset = 0
    while True:
        r = await http.get("/jobs", params={"limit": 1000, "offset": offset})
        page = r.json()
        out.update((job["jobID"], job["status"]) for job in page["jobs"])
        offset += 1000
        if offset >= page["numberMatched"]:
            return out


async def _load(
    base: str, jobs: int, clients: int, batch: int, inputs: dict[str, Any], seconds: float
) -> LoadReport:
    report = LoadReport(jobs)
    probe = _Probe(base, report)
    probe.start()
    t0 = time.monotonic()
    deadline = t0 + seconds
    # Idle connections are dropped before the server's keep-alive timeout (5 s) would close
    # them under a request.
    limits = httpx.Limits(
        max_connections=clients, max_keepalive_connections=clients, keepalive_expiry=2.0
    )
    try:
        async with httpx.AsyncClient(base_url=base, timeout=60, limits=limits) as http:
            shares = [jobs // clients + (i < jobs % clients) for i in range(clients)]
            per_client = await asyncio.gather(
                *(_one_client(http, n, batch, inputs, report, probe, deadline) for n in shares)
            )
            report.seconds = time.monotonic() - t0
            ids = {job_id for chunk in per_client for job_id in chunk}
            report.accepted = len(ids)
            stored = await _statuses(http)  # the final word: the store's
            report.stored = len(stored)
            for job_id in ids:
                status = stored.get(job_id)
                report.final += status in FINAL
                report.successful += status == "successful"
                report.lost += status not in FINAL
    finally:
        probe.stop.set()
        probe.join(30)
    if report.latencies:
        ordered = sorted(report.latencies)
        report.status_p50 = statistics.median(ordered)
        report.status_p99 = ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))]
        report.status_max = ordered[-1]
    return report


def run_load(
    base: str,
    *,
    jobs: int,
    clients: int,
    inputs: dict[str, Any],
    deadline: float,
    batch: int = 10,
) -> LoadReport:
    """``jobs`` mesh jobs of ``inputs`` from ``clients`` concurrent clients (each submits half
    its jobs one by one, the rest in batches of ``batch``), within ``deadline`` seconds."""
    return asyncio.run(_load(base, jobs, clients, batch, inputs, deadline))
