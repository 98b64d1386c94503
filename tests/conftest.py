"""Shared fixtures: the public cases copied into tests/data."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

DATA = Path(__file__).resolve().parent / "data"
CASES = sorted(p.stem for p in (DATA / "cases").glob("*.geojson"))


def load_case(name: str) -> dict[str, Any]:
    """A public case as its GeoJSON Feature."""
    return json.loads((DATA / "cases" / f"{name}.geojson").read_text())


@pytest.fixture(params=CASES)
def case(request: pytest.FixtureRequest) -> dict[str, Any]:
    return load_case(request.param)
