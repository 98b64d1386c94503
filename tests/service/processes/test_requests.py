"""The typed requests that cross to a worker: what a job stores is their JSON, and a worker
rebuilds the same request from it (also from jobs stored by older versions)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import orjson
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine
from service import processes
from service.cli import main
from service.jobs.task import unpack
from service.processes import PROCESSES, inputs_at, mesh, quality, smooth
from service.settings import Settings

from ..conftest import SQUARE

CASES = Path(__file__).resolve().parents[2] / "data" / "cases"


def _request(process: str, inputs: dict[str, Any]) -> Any:
    module = {"mesh": mesh, "smooth": smooth, "quality": quality}[process]
    model = PROCESSES[process].inputs_model.model_validate(inputs)
    request, _ = module.prepare(model, Settings(_env_file=None), inputs_at("/inputs"))
    return request


def _stored(request: Any) -> dict[str, Any]:
    """What the store gives back: the request's JSON, round-tripped through bytes."""
    data: dict[str, Any] = json.loads(json.dumps(request.to_json()))
    return data


@settings(max_examples=25, deadline=None)
@given(
    size=st.floats(0.05, 0.5),
    growth=st.floats(1.05, 3.0),
    seed=st.integers(0, 2**63 - 1),
    method=st.sampled_from(sorted(engine.SMOOTHERS)),
    resample=st.booleans(),
)
def test_a_mesh_request_comes_back_from_its_json(
    size: float, growth: float, seed: int, method: str, resample: bool
) -> None:
    inputs = {
        "boundary": SQUARE,
        "size": size,
        "growth": growth,
        "resample": resample,
        "smoothing": {"method": method, "seed": seed},
    }
    request = _request("mesh", inputs)
    again = mesh.MeshRequest.from_json(_stored(request))
    assert again == request
    assert again.seed == seed
    assert again.smoothing.method == method
    assert again.sizing == engine.SizingParams(size, growth, resample=resample)


def test_smooth_and_quality_requests_come_back_from_their_json() -> None:
    triangle = {"points": [[0, 0], [1, 0], [0, 1], [1, 1]], "triangles": [[0, 1, 2], [1, 3, 2]]}
    smoothing = {"method": "laplacian", "iterations": 7, "seed": 11}
    request = _request("smooth", {"mesh": triangle, "swap": False, "smoothing": smoothing})
    assert smooth.SmoothRequest.from_json(_stored(request)) == request
    assert (request.seed, request.smoothing.iterations, request.swap) == (11, 7, False)
    request = _request("quality", {"mesh": triangle, "fitness": "combined", "alpha": 0.5})
    assert quality.QualityRequest.from_json(_stored(request)) == request
    assert (request.params.fitness, request.params.alpha) == ("combined", 0.5)


def test_the_seed_is_chosen_once_and_kept() -> None:
    request = _request("mesh", {"boundary": SQUARE, "size": 0.2})
    assert 0 <= request.seed < 2**63
    assert _stored(request)["smoothing"]["seed"] == request.seed


def test_a_job_stored_before_the_newer_members_still_runs() -> None:
    payload = {
        "parts": [[[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], []]],
        "size": 0.25,
        "growth": 1.2,
        "size_min": None,
        "size_max": None,
        "swap": True,
        "smoothing": {"method": "none"},  # no seed: it ran with 0
        "max_triangles": 1000,
    }
    request = mesh.MeshRequest.from_json(payload)
    assert (request.seed, request.sizing.resample, request.refinements) == (0, False, [])
    data, figures = processes.run("mesh", payload, lambda p, m: None, lambda: False)
    doc = orjson.loads(unpack(data))
    assert doc["summary"]["parameters"]["seed"] == 0
    assert figures["triangles"] == len(doc["triangles"]) > 10


@pytest.mark.parametrize("case", ["l_shape", "annulus"])
def test_the_command_line_and_a_job_make_the_same_document(case: str, tmp_path: Path) -> None:
    out = tmp_path / "cli.json"
    args = ["mesh", str(CASES / f"{case}.geojson"), "--smooth", "laplacian", "--seed", "5"]
    assert main([*args, "-o", str(out)]) == 0
    boundary = json.loads((CASES / f"{case}.geojson").read_text())
    request = _request(
        "mesh", {"boundary": boundary, "smoothing": {"method": "laplacian", "seed": 5}}
    )
    data, _ = processes.run("mesh", _stored(request), lambda p, m: None, lambda: False)
    job, cli = orjson.loads(unpack(data)), json.loads(out.read_text())
    for doc in (job, cli):
        doc["summary"].pop("timings")
        doc["summary"]["parameters"].pop("max_triangles")  # the service's limit, or the engine's
        for sweep in doc["summary"]["history"]:
            sweep.pop("seconds", None)
    assert job == cli
