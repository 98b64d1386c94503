"""Progress on the command line: rich bars on a terminal, plain lines otherwise.

A terminal gets live bars (rich, imported only then); a pipe or a log file gets one line per
change worth reading (a new stage, a job finishing), never carriage-return animations.
"""

from __future__ import annotations

import sys
import threading
from typing import IO, TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rich.progress import Progress

__all__ = ["STAGE_LABELS", "StageBar", "is_terminal", "make_progress", "stage_label"]

#: What the engine's stages (and the job messages that name them) mean to a person.
STAGE_LABELS = {
    "accepted": "queued",
    "started": "starting",
    "boundary": "discretising the boundary",
    "mesh": "meshing",
    "swap": "swapping diagonals",
    "smooth": "smoothing",
    "quality": "assessing quality",
    "write": "writing the result",
    "done": "done",
}

#: Share of the whole run each engine stage covers, as the service's job progress counts it.
_STAGE_SPANS = {
    "boundary": (0.0, 0.05),
    "mesh": (0.05, 0.30),
    "swap": (0.30, 0.35),
    "smooth": (0.35, 0.99),
    "write": (0.99, 1.0),
}


def stage_label(message: str) -> str:
    """A job message or engine stage in words.

    >>> stage_label("smooth"), stage_label("worker lost")
    ('smoothing', 'worker lost')
    """
    return STAGE_LABELS.get(message, message)


def is_terminal(stream: IO[str] | None = None) -> bool:
    stream = stream or sys.stderr
    return bool(getattr(stream, "isatty", lambda: False)())


def make_progress(stream: IO[str] | None = None, *, transient: bool = False) -> Progress:
    """rich bars with a description, a bar, the percentage and the elapsed time."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        Progress,
        SpinnerColumn,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    return Progress(
        SpinnerColumn(),
        TextColumn("[progress.description]{task.description}"),
        BarColumn(bar_width=None),
        TaskProgressColumn(),
        TimeElapsedColumn(),
        console=Console(file=stream or sys.stderr),
        transient=transient,
        expand=False,
    )


class StageBar:
    """The engine's ``progress(stage, fraction)`` shown as one bar, once a run takes long.

    Short runs print nothing; after ``delay`` seconds a terminal gets a bar that follows the
    stages and disappears at the end. Not on a terminal, nothing is printed (the command's own
    summary line says what happened).
    """

    def __init__(self, stream: IO[str] | None = None, delay: float = 0.8) -> None:
        self._stream = stream or sys.stderr
        self._enabled = is_terminal(self._stream)
        self._delay = delay
        self._lock = threading.Lock()
        self._bar: Progress | None = None
        self._task: Any = None
        self._state = ("boundary", 0.0)
        self._timer: threading.Timer | None = None
        self._closed = False

    def __call__(self, stage: str, fraction: float) -> None:
        with self._lock:
            self._state = (stage, fraction)
            self._update()

    def _overall(self) -> float:
        stage, fraction = self._state
        lo, hi = _STAGE_SPANS.get(stage, (0.0, 0.99))
        return 100 * (lo + (hi - lo) * min(max(fraction, 0.0), 1.0))

    def _update(self) -> None:
        if self._bar is not None:
            self._bar.update(
                self._task, completed=self._overall(), description=stage_label(self._state[0])
            )

    def _show(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._bar = make_progress(self._stream, transient=True)
            self._task = self._bar.add_task(stage_label(self._state[0]), total=100)
            self._update()
            self._bar.start()

    def __enter__(self) -> StageBar:
        if self._enabled:
            self._timer = threading.Timer(self._delay, self._show)
            self._timer.daemon = True
            self._timer.start()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._timer is not None:
            self._timer.cancel()
        with self._lock:
            self._closed = True
            if self._bar is not None:
                self._bar.stop()
