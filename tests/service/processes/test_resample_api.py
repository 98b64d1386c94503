"""Digitised boundaries through the API (issue 17): a dense boundary is refused with a hint to
resample, and accepted with ``resample``, its result reporting the boundary's deviation."""

from __future__ import annotations

from typing import Any

import httpx
import numpy as np
import pytest

from ..conftest import ClientFactory, assert_problem, submit, wait_for

pytestmark = pytest.mark.anyio

NONE = {"method": "none"}


def _ellipse(n: int = 20_000, a: float = 1000.0, b: float = 600.0) -> dict[str, Any]:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return {"outer": np.c_[a * np.cos(t), b * np.sin(t)].tolist()}


@pytest.fixture
async def limited(make_client: ClientFactory) -> httpx.AsyncClient:
    return await make_client(max_triangles=10_000)


async def test_a_dense_ellipse_is_refused_then_resampled(limited: httpx.AsyncClient) -> None:
    inputs: dict[str, Any] = {"boundary": _ellipse(), "size": 100.0, "smoothing": NONE}
    r = await limited.post("/processes/mesh/execution", json={"inputs": inputs})
    doc = assert_problem(r, 422, "limit-exceeded", "/inputs/size")
    assert "resample: true" in doc["detail"]
    job = await submit(limited, "mesh", {**inputs, "resample": True, "resample_tolerance": 5.0})
    status = await wait_for(limited, job["jobID"])
    assert status["status"] == "successful", status
    result = (await limited.get(f"/jobs/{job['jobID']}/results")).json()
    boundary = result["summary"]["smoothed"]["boundary"]
    assert 0 < boundary["max_deviation"] <= 5.0
    assert boundary["vertices_before"] == 20_000
    assert result["summary"]["parameters"]["sizing"]["resample"] is True
    area_count = np.pi * 1000.0 * 600.0 / (np.sqrt(3) / 4 * 100.0**2)
    assert abs(len(result["triangles"]) - area_count) <= 0.3 * area_count


async def test_resample_tolerance_must_be_positive(limited: httpx.AsyncClient) -> None:
    inputs = {"boundary": _ellipse(100), "size": 100.0, "resample": True, "resample_tolerance": 0}
    r = await limited.post("/processes/mesh/execution", json={"inputs": inputs})
    assert_problem(r, 422)
