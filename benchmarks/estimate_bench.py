"""Triangle-count estimate against the real mesh, and the size field's cost on thin features.

Prints, never asserts. Table 1: ``engine.estimate_triangles`` against ``engine.mesh_region`` on
the public cases (``tests/data/cases``, size ``h`` from each Feature), spikes 1e-2 and 1e-3 wide
on a unit square, a 100:1 channel, a short segment, a 2,000-vertex digitised ellipse and a random
60-vertex star. Table 2 (no meshing): the 1e-6-wide spike and the 20,000-vertex ellipse 0.3
apart at size 100 (292,706 real triangles, measured on main), a 100,000-vertex ellipse at size 100
and a unit square at size 1e-4 capped at a million triangles (refused at once). Writes
``benchmarks/results/estimate.json``. Run: ``python benchmarks/estimate_bench.py``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from record import write_rows

import engine
from engine.estimate import estimate_triangles
from engine.sizing import build_size_field

CASES = Path(__file__).resolve().parents[1] / "tests" / "data" / "cases"


def spike(width: float) -> engine.Region:
    w = width / 2
    ring = [[0, 0], [1, 0], [1, 1], [0.5 + w, 1], [0.5 + w, 2], [0.5 - w, 2], [0.5 - w, 1], [0, 1]]
    return engine.make_region([(ring, [])])


def ellipse(n: int, a: float, b: float) -> engine.Region:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return engine.make_region([(np.c_[a * np.cos(t), b * np.sin(t)], [])])


def cases() -> list[tuple[str, engine.Region, float]]:
    out = []
    for path in sorted(CASES.glob("*.geojson")):
        doc = json.loads(path.read_text())
        rings = doc["geometry"]["coordinates"]
        out.append((path.stem, engine.make_region([(rings[0], rings[1:])]), doc["properties"]["h"]))
    rng = np.random.default_rng(1)
    ang, rad = np.sort(rng.uniform(0, 2 * np.pi, 60)), rng.uniform(0.3, 1, 60)
    out += [
        ("spike 1e-2", spike(1e-2), 0.5),
        ("spike 1e-3", spike(1e-3), 0.5),
        ("channel 100:1", engine.make_region([([[0, 0], [1, 0], [1, 0.01], [0, 0.01]], [])]), 0.05),
        ("short segment",
         engine.make_region([([[0, 0], [1, 0], [1, 0.001], [1, 1], [0, 1]], [])]), 0.05),
        ("ellipse 2k vertices", ellipse(2000, 120.0, 70.0), 20.0),
        ("random star 60", engine.make_region([(np.c_[rad * np.cos(ang), rad * np.sin(ang)], [])]),
         0.05),
    ]  # fmt: skip
    return out


def main() -> None:
    rows: list[dict[str, Any]] = []
    print(f"{'case':22s} {'estimate':>9s} {'real':>9s} {'ratio':>6s} {'est s':>6s}")
    for name, region, h in cases():
        t0 = time.perf_counter()
        estimate = estimate_triangles(region, build_size_field(region, engine.SizingParams(h)))
        seconds = time.perf_counter() - t0
        mesh, _ = engine.mesh_region(region, engine.SizingParams(h))
        ratio = estimate / mesh.n_triangles
        rows.append({"case": name, "estimate": estimate, "real": mesh.n_triangles,
                     "ratio": round(ratio, 3), "estimate_s": round(seconds, 3)})  # fmt: skip
        print(f"{name:22s} {estimate:9d} {mesh.n_triangles:9d} {ratio:6.3f} {seconds:6.3f}")
    square = engine.make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    big = [("spike 1e-6", spike(1e-6), 0.5, None, 5_000_000),
           ("ellipse 20k, size 100", ellipse(20_000, 1200.0, 700.0), 100.0, 292_706, 5_000_000),
           ("ellipse 100k, size 100", ellipse(100_000, 1200.0, 700.0), 100.0, None, 5_000_000),
           ("square 1e-4, cap 1e6", square, 1e-4, None, 1_000_000)]  # fmt: skip
    for name, region, h, real, cap in big:
        t0 = time.perf_counter()
        field = build_size_field(region, engine.SizingParams(h))
        t1 = time.perf_counter()
        estimate = estimate_triangles(region, field, cap=cap)
        seconds, field_s = time.perf_counter() - t0, t1 - t0
        rows.append({"case": name, "estimate": estimate, "real": real or "",
                     "ratio": round(estimate / real, 3) if real else "",
                     "estimate_s": round(seconds, 3), "field_s": round(field_s, 3)})  # fmt: skip
        print(
            f"{name:22s} {estimate:9d} {real or '-':>9} {seconds:6.3f} s "
            f"(field {field_s:.3f} s), {field.samples} samples"
        )
    write_rows(
        "estimate",
        rows,
        title="Triangle estimate against the real mesh",
        notes="engine.estimate_triangles (size field + estimate, seconds) against mesh_region; "
        "the 20k ellipse's real count was measured on main; the 1e-6 spike, the 100k ellipse and "
        "the capped square are only estimated (field_s: the size field's share of estimate_s).",
    )


if __name__ == "__main__":
    main()
