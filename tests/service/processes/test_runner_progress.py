"""The workers' side of a job: honest progress (issue 15 goal 5) and the GA's node selection
passed from the request to the engine (issue 15 goal 1)."""

from __future__ import annotations

import json
from typing import Any

import orjson
import pytest

from engine.pipeline import STAGE_WORDS
from service import processes
from service.jobs.task import unpack
from service.processes import PROCESSES, inputs_at
from service.settings import Settings

from ..conftest import SQUARE

SMALL_GA = {"method": "ga", "population": 8, "generations": 4, "max_sweeps": 2, "seed": 5}


def _stored(inputs: dict[str, Any], process: str = "mesh") -> dict[str, Any]:
    """What a job stores for ``inputs``: the prepared, JSON round-tripped payload."""
    proc = PROCESSES[process]
    model = proc.inputs_model.model_validate(inputs)
    settings = Settings(_env_file=None)  # type: ignore[call-arg]
    prepared = proc.prepare(model, settings, inputs_at("/inputs"))
    stored: dict[str, Any] = json.loads(json.dumps(prepared.inputs))
    return stored


def _run(process: str, payload: dict[str, Any]) -> tuple[dict[str, Any], list[tuple[int, str]]]:
    seen: list[tuple[int, str]] = []
    data, _ = processes.run(process, payload, lambda p, m: seen.append((p, m)), lambda: False)
    doc: dict[str, Any] = orjson.loads(unpack(data))
    return doc, seen


@pytest.mark.parametrize("selection", ["poor", "all"])
def test_a_mesh_jobs_progress_only_rises_and_names_stages_in_words(selection: str) -> None:
    payload = _stored(
        {"boundary": SQUARE, "size": 0.1, "smoothing": {**SMALL_GA, "selection": selection}}
    )
    doc, seen = _run("mesh", payload)
    percents = [p for p, _ in seen]
    assert percents == sorted(percents), percents
    assert percents[0] >= 0
    assert percents[-1] <= 99
    assert {m for _, m in seen} <= set(STAGE_WORDS.values()), {m for _, m in seen}
    assert {"meshing (advancing front)", "smoothing"} <= {m for _, m in seen}
    # Not the old fixed ranges: meshing ends where its measured cost says (not at 30 %).
    mesh_end = max(p for p, m in seen if m == "meshing (advancing front)")
    assert mesh_end != 30
    assert doc["summary"]["parameters"]["smoothing"]["selection"] == selection


def test_a_smooth_jobs_progress_starts_at_zero() -> None:
    mesh_doc, _ = _run("mesh", _stored({"boundary": SQUARE, "size": 0.2, "smoothing": SMALL_GA}))
    payload = _stored({"mesh": {k: mesh_doc[k] for k in ("points", "triangles")}}, "smooth")
    payload["smoothing"].update(population=8, generations=4, max_sweeps=2)
    _, seen = _run("smooth", payload)
    percents = [p for p, _ in seen]
    assert percents == sorted(percents)
    assert percents[0] < 10, percents
    assert percents[-1] >= 90, percents


def test_selection_options_reach_the_engine_and_are_described() -> None:
    smoothing = {**SMALL_GA, "selection": "all", "poor_quality": 0.7, "patience": None}
    payload = _stored({"boundary": SQUARE, "size": 0.2, "smoothing": smoothing})
    assert payload["smoothing"]["selection"] == "all"
    assert payload["smoothing"]["poor_quality"] == 0.7
    assert payload["smoothing"]["patience"] is None
    doc, _ = _run("mesh", payload)
    used = doc["summary"]["parameters"]["smoothing"]
    assert (used["selection"], used["poor_quality"], used["patience"]) == ("all", 0.7, None)
    schema = PROCESSES["mesh"].inputs_model.model_json_schema()
    fields = schema["$defs"]["SmoothingInput"]["properties"]
    assert fields["selection"]["default"] == "poor"
    assert fields["selection"]["enum"] == ["poor", "all"]
    assert fields["poor_quality"]["default"] == 0.9
    assert fields["patience"]["default"] == 15


def test_a_lonlat_job_stored_before_the_crs_input_still_comes_back_in_lonlat() -> None:
    ring = [[7.0, 46.0], [7.01, 46.0], [7.01, 46.01], [7.0, 46.01]]
    payload = _stored({"boundary": SQUARE, "size": 0.5, "smoothing": {"method": "none"}})
    del payload["crs"]
    payload.update(parts=[(ring, [])], coordinates="wgs84", size=300.0)
    doc, _ = _run("mesh", payload)
    assert doc["crs"]["mesh"] == "EPSG:32632"
    lon = [p[0] for p in doc["points"]]
    assert min(lon) >= 7.0 - 1e-7  # edges straight in the plane bow by ~1e-8 degrees
    assert max(lon) <= 7.01 + 1e-7
