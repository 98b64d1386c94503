"""The console script exists and reports the package version."""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

import pytest

from service.cli import main


def _evomesh() -> str:
    return str(Path(sys.executable).parent / "evomesh")


def test_version_is_the_package_metadata_version() -> None:
    out = subprocess.run([_evomesh(), "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == f"evomesh {version('evomesh')}"


def test_help_lists_subcommands(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    for command in ("mesh", "smooth", "quality", "serve"):
        assert command in text


def test_no_command_prints_help_and_fails(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 2
    assert "usage: evomesh" in capsys.readouterr().out
