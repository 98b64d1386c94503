"""Benchmark result files: each script writes its rows to ``benchmarks/results/<name>.json``.

The docs' benchmark tables are generated from these files, so every figure in the docs is one a
script measured. A file holds a title, notes, the machine it ran on and a list of rows (one JSON
object per table row, keys in column order).
"""

from __future__ import annotations

import json
import os
import platform
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parent / "results"


def write_rows(name: str, rows: list[dict[str, Any]], *, title: str = "", notes: str = "") -> Path:
    """Write ``rows`` to ``benchmarks/results/<name>.json`` and return the path."""
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / f"{name}.json"
    doc = {
        "title": title,
        "notes": notes,
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}",
        "rows": rows,
    }
    path.write_text(json.dumps(doc, indent=1) + "\n")
    return path
