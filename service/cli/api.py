"""The service's HTTP API for the command line: httpx, problem documents turned into one line.

>>> problem_line({"title": "Unprocessable Entity", "detail": "size must be positive",
...               "pointer": "/inputs/size"})
'Unprocessable Entity: size must be positive (at /inputs/size)'
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import httpx

__all__ = ["DEFAULT_URL", "Api", "ClientError", "format_for", "problem_line"]

DEFAULT_URL = "http://127.0.0.1:8000"

#: Result formats by the extension of an output file.
_EXTENSIONS = {
    ".json": "json",
    ".geojson": "geojson",
    ".vtu": "vtu",
    ".msh": "msh",
    ".svg": "svg",
    ".png": "png",
}


class ClientError(Exception):
    """What went wrong talking to the service, as one line; ``code`` is the exit status:
    2 when the request was refused (4xx: the input's fault), 1 otherwise."""

    def __init__(self, message: str, code: int = 1) -> None:
        super().__init__(message)
        self.code = code


def problem_line(problem: Mapping[str, Any]) -> str:
    """An RFC 9457 problem as ``title: detail (at pointer)``."""
    title = str(problem.get("title") or "Error")
    detail = " ".join(str(problem.get("detail") or "").split())
    line = f"{title}: {detail}" if detail else title
    pointer = problem.get("pointer")
    if pointer and pointer not in detail:
        line += f" (at {pointer})"
    return line


def format_for(path: str | Path) -> str:
    """The ``f`` value of an output file's extension.

    >>> format_for("out.PNG"), format_for("mesh.vtu")
    ('png', 'vtu')
    """
    suffix = Path(path).suffix.lower()
    if suffix not in _EXTENSIONS:
        choices = ", ".join(_EXTENSIONS)
        raise ClientError(f"unsupported output format {suffix!r}; use one of {choices}", 2)
    return _EXTENSIONS[suffix]


class Api:
    """A client of one evomesh service."""

    def __init__(self, url: str, api_key: str | None = None, timeout: float = 60.0) -> None:
        self.url = url.rstrip("/")
        headers = {"Accept": "application/json", "User-Agent": "evomesh-cli"}
        key = api_key if api_key is not None else os.environ.get("EVOMESH_API_KEY")
        if key:
            headers["X-API-Key"] = key
        self.http = httpx.Client(base_url=self.url, headers=headers, timeout=timeout)

    def close(self) -> None:
        self.http.close()

    def __enter__(self) -> Api:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def request(self, method: str, path: str, **kwargs: Any) -> httpx.Response:
        try:
            r = self.http.request(method, path, **kwargs)
        except httpx.TransportError as exc:
            raise ClientError(f"cannot reach {self.url}: {exc or type(exc).__name__}") from None
        if r.status_code >= 400:
            try:
                problem = r.json()
            except ValueError:
                problem = {"title": r.reason_phrase, "detail": r.text[:200]}
            if not isinstance(problem, dict):
                problem = {"title": r.reason_phrase, "detail": str(problem)[:200]}
            raise ClientError(problem_line(problem), 2 if r.status_code < 500 else 1)
        return r

    def json(self, method: str, path: str, **kwargs: Any) -> dict[str, Any]:
        body: dict[str, Any] = self.request(method, path, **kwargs).json()
        return body

    def execute(self, process: str, inputs: dict[str, Any]) -> dict[str, Any]:
        return self.json("POST", f"/processes/{process}/execution", json={"inputs": inputs})

    def job(self, job_id: str) -> dict[str, Any]:
        return self.json("GET", f"/jobs/{job_id}")

    def jobs(self, **params: Any) -> dict[str, Any]:
        return self.json("GET", "/jobs", params=params)

    def batch(self, body: dict[str, Any]) -> dict[str, Any]:
        return self.json("POST", "/batches", json=body)

    def batch_status(self, batch_id: str) -> dict[str, Any]:
        return self.json("GET", f"/batches/{batch_id}")

    def dismiss(self, job_id: str) -> dict[str, Any]:
        return self.json("DELETE", f"/jobs/{job_id}")

    def result(self, job_id: str, fmt: str = "json") -> bytes:
        return self.request("GET", f"/jobs/{job_id}/results", params={"f": fmt}).content
