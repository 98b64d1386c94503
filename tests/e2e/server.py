"""A real ``evomesh serve`` on a free loopback port, with its own data directory."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import httpx


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def descendants(pid: int) -> dict[int, int]:
    """Every live descendant of ``pid`` and its depth (1 = child), from /proc."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            # The command name may hold spaces; fields after the closing parenthesis are fixed.
            fields = stat.rsplit(")", 1)[1].split()
            if fields[0] != "Z":
                parents[int(entry.name)] = int(fields[1])
    out: dict[int, int] = {}
    frontier, depth = [pid], 0
    while frontier:
        depth += 1
        frontier = [p for p, parent in parents.items() if parent in frontier]
        out.update(dict.fromkeys(frontier, depth))
    return out


class Server:
    """``evomesh serve`` as a subprocess; its log goes to a file in ``data_dir``."""

    def __init__(self, data_dir: Path, workers: int | None = 1, **env: str) -> None:
        self.data_dir = data_dir
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log_path = data_dir / f"server-{self.port}.log"
        data_dir.mkdir(parents=True, exist_ok=True)
        evomesh = str(Path(sys.executable).parent / "evomesh")
        cmd = [evomesh, "serve", "--host", "127.0.0.1", "--port", str(self.port)]
        cmd += ["--data-dir", str(data_dir)]
        if workers is not None:  # None: the server's default (one per CPU)
            cmd += ["--workers", str(workers)]
        self._log = self.log_path.open("wb")
        self.proc = subprocess.Popen(
            cmd, stdout=self._log, stderr=subprocess.STDOUT, env={**os.environ, **env}
        )
        self.client = httpx.Client(base_url=self.url, timeout=30)
        try:
            self._wait_ready()
        except BaseException:
            self.stop(signal.SIGKILL)  # leave no server, socket or log file behind
            raise

    # Workers load the engine's kernels before the service is ready: seconds from the numba
    # cache (make test fills it first), minutes on a busy machine without one.
    def _wait_ready(self, timeout: float = 240.0) -> None:
        deadline = time.monotonic() + timeout
        while True:
            assert self.proc.poll() is None, f"the server exited: {self.log()}"
            try:
                if self.client.get("/ready").status_code == 200:
                    return
            except httpx.TransportError:
                pass
            assert time.monotonic() < deadline, f"not ready in {timeout} s: {self.log()}"
            time.sleep(0.05)

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")[-4000:]

    def workers(self) -> list[int]:
        """Worker processes: the forkserver's children (grandchildren of the server)."""
        return sorted(p for p, depth in descendants(self.proc.pid).items() if depth == 2)

    def wait(
        self,
        job_id: str,
        timeout: float = 120.0,
        statuses: tuple[str, ...] = ("successful", "failed", "dismissed"),
    ) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while True:
            doc: dict[str, Any] = self.client.get(f"/jobs/{job_id}").json()
            if doc["status"] in statuses:
                return doc
            assert time.monotonic() < deadline, f"{job_id} still {doc['status']}: {self.log()}"
            time.sleep(0.05)

    def stop(self, sig: int = signal.SIGTERM, timeout: float = 30.0) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout)
        self.client.close()
        self._log.close()
        return int(self.proc.returncode)
