"""Settings: read from EVOMESH_* variables (their docs table is generated: tests/test_docs.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from service.cli import build_parser
from service.settings import Settings


def test_environment_variables(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("EVOMESH_DATA_DIR", str(tmp_path))
    monkeypatch.setenv("EVOMESH_WORKERS", "3")
    monkeypatch.setenv("EVOMESH_API_KEYS", " a , b,")
    monkeypatch.setenv("EVOMESH_MAX_GA_WORK", "1e6")
    s = Settings()
    assert (s.data_dir, s.workers, s.api_keys, s.max_ga_work) == (tmp_path, 3, ["a", "b"], 1e6)
    assert s.database == tmp_path / "jobs.sqlite3"
    assert Settings(_env_file=None).cors_origins == []  # type: ignore[call-arg]
    monkeypatch.setenv("EVOMESH_WORKERS", "0")
    with pytest.raises(ValueError, match="workers"):
        Settings()


def test_serve_flags() -> None:
    args = build_parser().parse_args(
        ["serve", "--port", "9001", "--data-dir", "/tmp/x", "--workers", "2"]
    )
    assert (args.host, args.port, str(args.data_dir), args.workers) == (
        "127.0.0.1",
        9001,
        "/tmp/x",
        2,
    )
