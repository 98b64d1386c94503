"""Digitised boundaries with and without ``resample``: triangle count against the area's.

Prints, never asserts. Each digitised region is meshed (``engine.mesh_then_smooth``, no
smoothing) with every input vertex kept and with ``resample`` (default tolerance, 0.1 of the
size). Columns: input vertices, boundary vertices after resampling, triangles, the area-based
count ``area / (sqrt(3)/4 h^2)`` and the ratio of the two, the largest deviation of the meshed
boundary from the input and the tolerance, and the seconds taken. No gmsh column: gmsh, too,
keeps every input vertex of a boundary it is given as points.

Run: ``python benchmarks/resample_bench.py``.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from record import write_rows

import engine
from engine import PipelineParams, SizingParams, SmoothingParams

NONE = SmoothingParams(method="none")


def ellipse(n: int, a: float, b: float) -> engine.Region:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return engine.make_region([(np.c_[a * np.cos(t), b * np.sin(t)], [])])


def noisy_rectangle(width: float, height: float, step: float, noise: float) -> engine.Region:
    rng = np.random.default_rng(7)
    corners = np.array([[0, 0], [width, 0], [width, height], [0, height]], dtype=float)
    pts = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0), strict=True):
        n = int(np.hypot(*(b - a)) / step)
        side = a + (np.arange(n) / n)[:, None] * (b - a)
        side[1:] += rng.uniform(-noise, noise, size=(n - 1, 2))
        pts.append(side)
    return engine.make_region([(np.concatenate(pts), [])])


def run(name: str, region: engine.Region, size: float, resample: bool) -> dict[str, Any]:
    sizing = SizingParams(size, resample=resample)
    started = time.perf_counter()
    result = engine.mesh_then_smooth(region, PipelineParams(sizing, smoothing=NONE))
    seconds = time.perf_counter() - started
    area_count = region.area / (np.sqrt(3) / 4 * size**2)
    triangles = result.smoothed.mesh.n_triangles
    boundary = result.smoothed.summary.get("boundary", {})
    return {
        "region": name,
        "size": size,
        "resample": "yes" if resample else "no",
        "input vertices": region.n_vertices,
        "vertices after": boundary.get("vertices_after", region.n_vertices),
        "triangles": triangles,
        "area count": round(area_count),
        "ratio": round(float(triangles / area_count), 2),
        "max deviation": round(boundary.get("max_deviation", 0.0), 3),
        "tolerance": round(boundary.get("tolerance", 0.0), 3),
        "seconds": round(seconds, 2),
    }


def main() -> None:
    engine.warmup()
    cases = [
        ("ellipse 1000x600, 20,000 vertices", ellipse(20_000, 1000.0, 600.0)),
        ("rectangle 1000x600 every 0.3, noise 0.05", noisy_rectangle(1000.0, 600.0, 0.3, 0.05)),
    ]
    rows = []
    for name, region in cases:
        for size, resample in ((100.0, True), (25.0, True), (100.0, False)):
            row = run(name, region, size, resample)
            print(row, flush=True)
            rows.append(row)
    write_rows(
        "resample",
        rows,
        title="Digitised boundaries: triangles with and without resample",
        notes="mesh_then_smooth without smoothing; default tolerance 0.1 of the size",
    )


if __name__ == "__main__":
    main()
