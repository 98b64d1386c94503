"""A Python client of an evomesh service, on httpx.

Submit a job, follow it, download its result::

    from service.client import Client

    with Client("http://127.0.0.1:8000") as client:
        job = client.mesh({"outer": [[0, 0], [4, 0], [4, 3], [0, 3]]}, size=0.25)
        job.wait(progress=lambda s: print(s.progress, s.message))
        doc = job.document()                  # the mesh document
        job.result("vtu", path="mesh.vtu")    # or any format of GET /jobs/{id}/results

Every refusal of the service raises :class:`ProblemError` carrying its RFC 9457 problem
(``status``, ``title``, ``detail``, ``pointer``); a job that ends badly raises :class:`JobFailed`
from :meth:`Job.wait`; a service that cannot be reached raises :class:`ConnectionFailed`. All
are :class:`ClientError`.

>>> ProblemError({"status": 422, "title": "Invalid input", "detail": "size must be positive",
...               "pointer": "/inputs/size"}).line
'Invalid input: size must be positive (at /inputs/size)'
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx

__all__ = [
    "DEFAULT_URL",
    "FINAL",
    "Batch",
    "Client",
    "ClientError",
    "ConnectionFailed",
    "Job",
    "JobFailed",
    "ProblemError",
    "Status",
    "WaitTimeout",
]

DEFAULT_URL = "http://127.0.0.1:8000"
#: The statuses a job does not leave.
FINAL = ("successful", "failed", "dismissed")


class ClientError(Exception):
    """Anything that went wrong talking to the service; ``line`` says it in one line."""

    @property
    def line(self) -> str:
        return " ".join(str(self).split())


class ConnectionFailed(ClientError):
    """The service could not be reached (refused, timed out, name not found)."""


class ProblemError(ClientError):
    """The service answered with an error: its problem document (RFC 9457)."""

    def __init__(self, problem: Mapping[str, Any]) -> None:
        self.problem = dict(problem)
        self.status = int(problem.get("status") or 0)
        self.title = str(problem.get("title") or "Error")
        self.detail = " ".join(str(problem.get("detail") or "").split())
        self.type = str(problem.get("type") or "about:blank")
        pointer = problem.get("pointer")
        self.pointer = str(pointer) if pointer else None
        super().__init__(self._line())

    def _line(self) -> str:
        line = f"{self.title}: {self.detail}" if self.detail else self.title
        if self.pointer and self.pointer not in self.detail:
            line += f" (at {self.pointer})"
        return line


class JobFailed(ClientError):
    """A job ended ``failed`` or ``dismissed``; ``status`` is its last :class:`Status`."""

    def __init__(self, status: Status) -> None:
        self.status = status
        what = "was dismissed" if status.status == "dismissed" else "failed"
        reason = f": {status.message}" if status.message else ""
        super().__init__(f"job {status.job_id} {what}{reason}")


class WaitTimeout(ClientError, TimeoutError):
    """A job or batch did not end within the time given to ``wait``."""


@dataclass(frozen=True)
class Status:
    """A job's status (the OGC ``statusInfo`` document; ``info`` holds all of it)."""

    job_id: str
    status: str  #: accepted | running | successful | failed | dismissed
    progress: int  #: percent
    message: str  #: the stage running, or why the job failed
    info: Mapping[str, Any] = field(repr=False, compare=False)

    @classmethod
    def of(cls, info: Mapping[str, Any]) -> Status:
        return cls(
            str(info["jobID"]),
            str(info["status"]),
            int(info.get("progress") or 0),
            str(info.get("message") or ""),
            info,
        )

    @property
    def done(self) -> bool:
        """The job will not change any more."""
        return self.status in FINAL


#: ``progress(status)``: called by ``wait`` whenever a job's status, progress or message changes.
ProgressCallback = Callable[[Status], None]


class Client:
    """A client of one evomesh service.

    ``api_key`` defaults to ``$EVOMESH_API_KEY``; ``timeout`` bounds each request (seconds);
    ``poll`` is the pause between two looks at a job while waiting; ``transport`` is handed to
    httpx (an ``httpx.MockTransport`` in tests, an ``httpx.HTTPTransport(retries=3)``...).
    """

    def __init__(
        self,
        url: str = DEFAULT_URL,
        api_key: str | None = None,
        *,
        timeout: float = 60.0,
        poll: float = 0.25,
        transport: httpx.BaseTransport | None = None,
    ) -> None:
        self.url = url.rstrip("/")
        self.poll = poll
        headers = {"Accept": "application/json", "User-Agent": "evomesh-client"}
        key = api_key if api_key is not None else os.environ.get("EVOMESH_API_KEY")
        if key:
            headers["X-API-Key"] = key
        self.http = httpx.Client(
            base_url=self.url, headers=headers, timeout=timeout, transport=transport
        )

    def close(self) -> None:
        self.http.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Client({self.url!r})"

    # -- HTTP -------------------------------------------------------------------------------------

    def request(self, method: str, path: str, **kwargs: Any) -> httpx.Response:
        """One request; :class:`ProblemError` on an error status, :class:`ConnectionFailed`
        when the service cannot be reached."""
        try:
            r = self.http.request(method, path, **kwargs)
        except httpx.TransportError as exc:
            raise ConnectionFailed(
                f"cannot reach {self.url}: {exc or type(exc).__name__}"
            ) from None
        if r.status_code >= 400:
            raise ProblemError(_problem(r))
        return r

    def get_json(self, path: str, **params: Any) -> dict[str, Any]:
        """``GET path`` as JSON."""
        body: dict[str, Any] = self.request("GET", path, params=params or None).json()
        return body

    # -- processes --------------------------------------------------------------------------------

    def execute(self, process: str, inputs: Mapping[str, Any]) -> Job:
        """Run ``process`` with ``inputs`` (as ``POST /processes/{process}/execution``)."""
        r = self.request("POST", f"/processes/{process}/execution", json={"inputs": inputs})
        return Job(self, Status.of(r.json()).job_id, process)

    def mesh(self, region: Any, size: float | None = None, **inputs: Any) -> Job:
        """Mesh ``region``: GeoJSON (a dict, a file path, or an object with
        ``__geo_interface__`` such as a shapely polygon) or ``{"outer": ..., "holes": ...}``.

        ``size`` is the target edge length (default: the region's ``h`` property); any other
        input of ``GET /processes/mesh`` is a keyword: ``growth=1.3``, ``swap=False``,
        ``coordinates="wgs84"``, ``smoothing={"method": "ga", "seed": 7}``.
        """
        if size is not None:
            inputs["size"] = size
        return self.execute("mesh", {"boundary": _region(region), **inputs})

    def smooth(self, mesh: Any, **inputs: Any) -> Job:
        """Swap and smooth a mesh (a mesh document, or a path to one: .json, .vtu, .msh);
        ``smoothing={...}`` and ``swap=False`` as for :meth:`mesh`."""
        return self.execute("smooth", {"mesh": _mesh(mesh), **inputs})

    def quality(self, mesh: Any, **inputs: Any) -> Job:
        """Assess a mesh (a mesh document or a path to one, as for :meth:`smooth`)."""
        return self.execute("quality", {"mesh": _mesh(mesh), **inputs})

    def batch(
        self, requests: Sequence[Mapping[str, Any]], process: str = "mesh", **inputs: Any
    ) -> Batch:
        """Many jobs of one process at once: ``requests`` are their inputs, laid over the
        shared ``inputs`` (for ``mesh``, a region may stand for ``{"boundary": region}``).

        >>> # client.batch([{"boundary": a}, {"boundary": b, "size": 0.1}], size=0.2)
        """
        items = [{"inputs": _batch_item(r, process)} for r in requests]  # one execute request each
        body = {"process": process, "inputs": inputs, "requests": items}
        doc = self.request("POST", "/batches", json=body).json()
        jobs = [Job(self, str(j["jobID"]), process) for j in doc["jobs"]]
        return Batch(self, str(doc["batchID"]), jobs)

    # -- jobs -------------------------------------------------------------------------------------

    def job(self, job_id: str) -> Job:
        """A job already submitted (to this service), by its id."""
        return Job(self, job_id)

    def jobs(self, status: Sequence[str] = (), limit: int = 20) -> list[Status]:
        """The service's jobs, newest first; ``status`` keeps those with one of these."""
        params: dict[str, Any] = {"limit": limit}
        if status:
            params["status"] = list(status)
        return [Status.of(info) for info in self.get_json("/jobs", **params)["jobs"]]


class Job:
    """A job of a service: its status, its end, its results."""

    def __init__(self, client: Client, job_id: str, process: str | None = None) -> None:
        self.client = client
        self.id = job_id
        self.process = process

    def __repr__(self) -> str:
        return f"Job({self.id!r})"

    def status(self) -> Status:
        """The job's status now."""
        return Status.of(self.client.get_json(f"/jobs/{self.id}"))

    def wait(
        self,
        progress: ProgressCallback | None = None,
        timeout: float | None = None,
        *,
        check: bool = True,
    ) -> Status:
        """Wait for the job to end and return its last status.

        ``progress`` is called with each new status; ``timeout`` (seconds) raises
        :class:`WaitTimeout` (the job goes on); with ``check`` a job that failed or was
        dismissed raises :class:`JobFailed`.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        last: Status | None = None
        while True:
            now = self.status()
            if progress is not None and now != last:
                progress(now)
            last = now
            if now.done:
                if check and now.status != "successful":
                    raise JobFailed(now)
                return now
            if deadline is not None and time.monotonic() >= deadline:
                raise WaitTimeout(f"job {self.id} is still {now.status} after {timeout} s")
            time.sleep(self.client.poll)

    def result(
        self, format: str = "json", path: str | os.PathLike[str] | None = None, **options: Any
    ) -> bytes:
        """The result in ``format`` (``json``, ``geojson``, ``vtu``, ``msh``, ``svg``, ``png``),
        also written to ``path`` when given; ``options`` are the picture's (``color="min_angle"``,
        ``compare=1``, ``width=800``...). :class:`ProblemError` if the job has no result (yet).
        """
        params = {"f": format, **{k: str(v) for k, v in options.items()}}
        data = self.client.request("GET", f"/jobs/{self.id}/results", params=params).content
        if path is not None:
            Path(path).write_bytes(data)
        return data

    def document(self) -> dict[str, Any]:
        """The mesh document of a finished job (its ``json`` result, parsed)."""
        doc: dict[str, Any] = json.loads(self.result("json"))
        return doc

    def dismiss(self) -> Status:
        """Cancel the job if it runs, and forget its results."""
        return Status.of(self.client.request("DELETE", f"/jobs/{self.id}").json())


class Batch:
    """Jobs submitted together (``POST /batches``) and followed together."""

    def __init__(self, client: Client, batch_id: str, jobs: list[Job]) -> None:
        self.client = client
        self.id = batch_id
        self.jobs = jobs

    def __repr__(self) -> str:
        return f"Batch({self.id!r}, {len(self.jobs)} jobs)"

    def status(self) -> dict[str, Any]:
        """The batch's aggregated status: ``status``, ``progress``, ``counts`` and each job's."""
        return self.client.get_json(f"/batches/{self.id}")

    def wait(
        self,
        progress: Callable[[dict[str, Any]], None] | None = None,
        timeout: float | None = None,
    ) -> dict[str, Any]:
        """Wait until every job has ended; ``progress`` gets each new aggregated status. Jobs
        that failed do not raise: see ``counts`` and each :meth:`Job.status`."""
        deadline = None if timeout is None else time.monotonic() + timeout
        last: dict[str, Any] | None = None
        while True:
            doc = self.status()
            if progress is not None and doc != last:
                progress(doc)
            last = doc
            if all(j["status"] in FINAL for j in doc["jobs"]):
                return doc
            if deadline is not None and time.monotonic() >= deadline:
                raise WaitTimeout(f"batch {self.id} is still {doc['status']} after {timeout} s")
            time.sleep(self.client.poll * 2)

    def dismiss(self) -> dict[str, Any]:
        """Dismiss every job of the batch."""
        body: dict[str, Any] = self.client.request("DELETE", f"/batches/{self.id}").json()
        return body


# -- inputs ---------------------------------------------------------------------------------------


def _problem(r: httpx.Response) -> dict[str, Any]:
    """The problem document of an error response (or one made from its status line)."""
    try:
        problem = r.json()
    except ValueError:
        problem = None
    if not isinstance(problem, dict):
        problem = {"title": r.reason_phrase, "detail": r.text[:200]}
    problem.setdefault("status", r.status_code)
    return problem


def _load(value: Any) -> Any:
    """A JSON file's content when ``value`` is a path, else ``value``."""
    if isinstance(value, str | os.PathLike):
        return json.loads(Path(value).read_text(encoding="utf-8"))
    return value


def _region(region: Any) -> Any:
    region = _load(region)
    geo = getattr(region, "__geo_interface__", None)
    return dict(geo) if geo is not None else region


def _mesh(mesh: Any) -> dict[str, Any]:
    if isinstance(mesh, str | os.PathLike) and Path(mesh).suffix.lower() != ".json":
        from .formats import format_of  # .vtu, .msh: the service's own readers

        doc = format_of(Path(mesh), "input").read(Path(mesh).read_bytes())
    else:
        doc = _load(mesh)
    # Only the mesh: the rest of a result document (cell data, summary) is not an input.
    keys = ("points", "triangles", "points_local", "projected")
    return {k: doc[k] for k in keys if k in doc}


def _batch_item(request: Mapping[str, Any], process: str) -> dict[str, Any]:
    if process == "mesh" and "boundary" not in request:
        return {"boundary": _region(request)}  # a region given as it is
    return dict(request)
