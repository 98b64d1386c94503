"""A real Dask cluster for end-to-end tests: ``dask scheduler`` and ``dask worker`` processes on
127.0.0.1, started as an operator would (see the README's "Scaling out with Dask")."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from .server import free_port

DASK = str(Path(sys.executable).parent / "dask")


class DaskCluster:
    """A scheduler on a fixed loopback port and single-threaded worker processes (each a
    ``dask worker`` with its nanny); logs go to files in ``folder``."""

    def __init__(self, folder: Path, workers: int = 2) -> None:
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        self.port = free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        self.scheduler: subprocess.Popen[bytes] | None = None
        self.workers: list[subprocess.Popen[bytes]] = []
        self._logs: list[Any] = []
        self._client: Any = None
        self.start_scheduler()
        for _ in range(workers):
            self.start_worker()
        self.wait_for_workers(workers)

    def _spawn(self, name: str, args: list[str]) -> subprocess.Popen[bytes]:
        log = (self.folder / f"{name}.log").open("ab")
        self._logs.append(log)
        return subprocess.Popen([DASK, *args], stdout=log, stderr=subprocess.STDOUT)

    def start_scheduler(self) -> None:
        args = ["scheduler", "--host", "127.0.0.1", "--port", str(self.port)]
        self.scheduler = self._spawn("scheduler", [*args, "--dashboard-address", "127.0.0.1:0"])

    def start_worker(self) -> None:
        n = len(self.workers)
        args = [
            "worker", self.address, "--host", "127.0.0.1", "--nthreads", "1", "--nworkers", "1",
            "--dashboard-address", "127.0.0.1:0", "--local-directory", str(self.folder / "work"),
        ]  # fmt: skip
        self.workers.append(self._spawn(f"worker-{n}", args))

    def client(self) -> Any:
        """A Dask client of the test's own, to look inside the cluster."""
        if self._client is None:
            from distributed import Client

            self._client = Client(self.address, timeout=30, set_as_default=False)
        return self._client

    def wait_for_workers(self, n: int, timeout: float = 120.0) -> None:
        self.client().wait_for_workers(n, timeout=timeout)

    def worker_pids(self) -> dict[str, int]:
        """Worker process ids by worker address."""
        pids: dict[str, int] = self.client().run(os.getpid)
        return pids

    def worker_running(self, job_id: str, timeout: float = 30.0) -> str:
        """The address of the worker processing a task of ``job_id``."""
        deadline = time.monotonic() + timeout
        while True:
            for worker, keys in self.client().processing().items():
                if any(job_id in str(key) for key in keys):
                    return str(worker)
            assert time.monotonic() < deadline, f"no worker processes {job_id}"
            time.sleep(0.02)

    def kill_scheduler(self) -> None:
        """kill -9 the scheduler. Its workers shut themselves down after a while (a worker does
        not reconnect): start new ones with the scheduler, as a process supervisor would."""
        self._close_client()
        assert self.scheduler is not None
        self.scheduler.kill()
        self.scheduler.wait(30)

    def _close_client(self) -> None:
        if self._client is not None:
            with contextlib.suppress(Exception):
                self._client.close(timeout=10)
            self._client = None

    def log(self) -> str:
        return "\n".join(
            f"== {p.name}\n{p.read_text(errors='replace')[-3000:]}"
            for p in sorted(self.folder.glob("*.log"))
        )

    def stop(self) -> None:
        self._close_client()
        procs = [*self.workers, *([self.scheduler] if self.scheduler else [])]
        for proc in procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for proc in procs:
            try:
                proc.wait(20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(10)
        for log in self._logs:
            log.close()
