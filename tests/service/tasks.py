"""Runners for tests, imported by worker processes: sleep, fail, crash, hang."""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from service.inputs import ExecuteRequest
from service.jobs.task import ProgressCallback, TaskError
from service.processes import Prepared, Process, Where
from service.settings import Settings

Stop = Callable[[], bool]


def echo(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Stop
) -> tuple[bytes, dict[str, Any]]:
    progress(50, "echo")
    return repr(payload).encode(), {"pid": os.getpid()}


def scribble(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Stop
) -> tuple[bytes, dict[str, Any]]:
    """Change the payload it was handed, and say what it saw."""
    payload.setdefault("items", []).append("scribbled")
    payload["seen"] = True
    return repr(payload).encode(), {}


def sleepy(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Stop
) -> tuple[bytes, dict[str, Any]]:
    """Sleep ``seconds`` in small steps, reporting progress and honouring ``should_stop``."""
    seconds = float(payload.get("seconds", 1.0))
    start = time.monotonic()
    while (elapsed := time.monotonic() - start) < seconds:
        if should_stop():
            raise RuntimeError("stopped")
        progress(int(100 * elapsed / seconds), "sleeping")
        time.sleep(0.01)
    return b'{"points": [], "triangles": []}', {"pid": os.getpid(), "triangles": 0}


def hang(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Stop
) -> tuple[bytes, dict[str, Any]]:
    """Ignore ``should_stop``: only killing the worker ends this."""
    deadline = time.monotonic() + float(payload.get("seconds", 60.0))
    while time.monotonic() < deadline:
        time.sleep(0.01)
    return b"", {}


def fail(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Stop
) -> tuple[bytes, dict[str, Any]]:
    raise TaskError(str(payload.get("reason", "bad input")))


def bug(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Stop
) -> tuple[bytes, dict[str, Any]]:
    raise ZeroDivisionError("division by zero")


def crash(
    payload: dict[str, Any], progress: ProgressCallback, should_stop: Stop
) -> tuple[bytes, dict[str, Any]]:
    """Kill the worker (after ``delay`` seconds): always, or only while the marker file does not
    exist yet."""
    marker = payload.get("marker")
    if marker is None or not Path(marker).exists():
        time.sleep(float(payload.get("delay", 0.0)))
        if marker is not None:
            Path(marker).touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return b'{"points": [], "triangles": []}', {"pid": os.getpid(), "triangles": 0}


class SleepInputs(BaseModel):
    model_config = ConfigDict(extra="forbid")

    seconds: float = Field(1.0, ge=0, le=120)
    marker: str | None = None
    delay: float = Field(0.0, ge=0, le=60)  #: crash: seconds of work before the crash


class SleepExecute(ExecuteRequest):
    inputs: SleepInputs


def _prepare(inputs: SleepInputs, settings: Settings, where: Where) -> Prepared:
    return Prepared(inputs.model_dump(), None, 0)


def process_for(name: str, runner: str) -> Process:
    """A process that runs a test runner (``sleepy``, ``crash``...)."""
    return Process(
        id=name,
        title=name,
        description=f"test process running {runner}",
        inputs_model=SleepInputs,
        execute_model=SleepExecute,
        runner=f"tests.service.tasks:{runner}",
        prepare=_prepare,
    )
