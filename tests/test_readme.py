"""The runnable examples of the README and of the docs (``docs/**/*.md``) work.

A fenced block tagged ``sh {.run}`` or ``python {.run}`` (a class the docs site keeps and GitHub
ignores) is run as a user would: shell blocks with
bash, Python blocks saved to a file and run as a script (so a block that starts worker
processes must guard its entry point with ``if __name__ == "__main__":``). Each runs in a fresh
folder, as if it were the clone's top folder (``tests`` is linked there, so the public cases are
found), with ``evomesh`` and ``python`` of this environment on ``PATH`` and ``TMPDIR`` unset.
A block tagged ``sh {.run .server}`` talks to a service: the test starts ``evomesh serve`` on a free
port and the block's ``http://127.0.0.1:8000`` is that server.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.e2e.server import Server

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
PAGES = [README, *sorted((ROOT / "docs").rglob("*.md"))]
_BLOCK = re.compile(r"^```(sh|python) \{\.run( \.server)?\}\n(.*?)^```", re.DOTALL | re.MULTILINE)
#: Where the examples say the service is (``make run``'s address).
SERVICE_URL = "http://127.0.0.1:8000"


def examples(text: str) -> list[tuple[str, bool, str]]:
    """``(language, needs a server, code)`` of each runnable block of a markdown text.

    >>> text = "```sh {.run}\\nls\\n```\\n```python\\nx\\n```\\n"
    >>> examples(text + "```sh {.run .server}\\ncurl\\n```\\n")
    [('sh', False, 'ls\\n'), ('sh', True, 'curl\\n')]
    """
    return [(m.group(1), bool(m.group(2)), m.group(3)) for m in _BLOCK.finditer(text)]


def _cases() -> list[object]:
    return [
        pytest.param(kind, server, code, id=f"{page.relative_to(ROOT).as_posix()}:{i}:{kind}")
        for page in PAGES
        for i, (kind, server, code) in enumerate(examples(page.read_text()))
    ]


def test_readme_has_runnable_examples() -> None:
    kinds = {(kind, server) for kind, server, _ in examples(README.read_text())}
    assert kinds == {("sh", False), ("sh", True), ("python", False)}


def test_readme_is_a_front_door() -> None:
    assert len(README.read_text().splitlines()) <= 250


def test_readme_quick_start_is_two_make_commands() -> None:
    text = README.read_text()
    quick = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    block = re.search(r"```sh\n(.*?)```", quick, re.DOTALL)
    assert block is not None
    commands = [line.split("#")[0].strip() for line in block.group(1).splitlines()]
    assert [c for c in commands if c] == ["make run", "make test"]


def test_examples_do_not_depend_on_tmpdir() -> None:
    # Without TMPDIR set, "$TMPDIR/x" is "/x": examples write into the current folder instead.
    for page in PAGES:
        for _, _, code in examples(page.read_text()):
            assert "TMPDIR" not in code, page


@pytest.mark.parametrize(("kind", "server", "code"), _cases())
def test_example_runs(kind: str, server: bool, code: str, tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != "TMPDIR"}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    work = tmp_path / "clone"
    work.mkdir()
    (work / "tests").symlink_to(ROOT / "tests")
    service = Server(tmp_path / "service") if server else None
    try:
        if service is not None:
            code = code.replace(SERVICE_URL, service.url)
        if kind == "sh":
            cmd = ["bash", "-euo", "pipefail", "-c", code]
        else:
            script = work / "example.py"
            script.write_text(code)
            cmd = [sys.executable, script.name]
        proc = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True, timeout=600)
    finally:
        if service is not None:
            service.stop()
    assert proc.returncode == 0, proc.stdout + proc.stderr
