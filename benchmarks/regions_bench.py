"""Sixteen regions side by side with gmsh: the seven public cases and nine shapes defined here.

Prints, never asserts. For each region: evomesh's mesher alone (``engine.mesh_region``), the
default pipeline (mesher, then what ``evomesh smooth`` runs: settle, swap, valence flips, GA at
the paper's parameters, seed 0), and gmsh Frontal-Delaunay with its ``Relocate2D`` optimiser at
the same size (when gmsh is installed; ``make bench`` installs it). Columns as in
``smooth_bench.py``; ``vs gmsh`` says whether the pipeline's worst and mean radius ratio at least
match gmsh's (the issue's aim). The extra shapes cover what the public cases do not: round outer
boundaries (disc, ellipse, annuli: shrinking fronts), holes divided finer than the size (plate3,
plate_hole_off), a strip, a channel with a notch and an irregular polygon.

Run: ``python benchmarks/regions_bench.py [--regions a,b] [--no-gmsh]``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from smooth_bench import HEADER, figures, gmsh_mesh, row, smooth

import engine
from service.geojson import parse_region

CASES = Path(__file__).resolve().parents[1] / "tests" / "data" / "cases"
Ring = list[list[float]]


def _circle(cx: float, cy: float, r: float, n: int, hole: bool = False) -> Ring:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    if hole:
        t = t[::-1]
    return np.c_[cx + r * np.cos(t), cy + r * np.sin(t)].tolist()


def _ellipse(a: float, b: float, n: int) -> Ring:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.c_[a * np.cos(t), b * np.sin(t)].tolist()


#: name -> (outer ring, holes, size)
EXTRA: dict[str, tuple[Ring, list[Ring], float]] = {
    "annulus_thin": (_circle(0, 0, 1, 200), [_circle(0, 0, 0.8, 160, True)], 0.03),
    "annulus_wide": (_circle(0, 0, 2, 200), [_circle(0, 0, 0.3, 60, True)], 0.06),
    "disc": (_circle(0, 0, 1, 160), [], 0.04),
    "ellipse": (_ellipse(2, 0.7, 200), [], 0.05),
    "plate3": (
        [[0, 0], [4, 0], [4, 2], [0, 2]],
        [
            _circle(1, 1, 0.4, 80, True),
            _circle(2.2, 0.8, 0.3, 60, True),
            _circle(3.2, 1.2, 0.35, 70, True),
        ],
        0.06,
    ),
    "polygon": (
        [[0, 0], [3, 0.2], [3.5, 1.5], [2.2, 2.8], [1.0, 2.0], [0.2, 2.6], [-0.5, 1.2]],
        [],
        0.07,
    ),
    "strip": ([[0, 0], [5, 0], [5, 0.5], [0, 0.5]], [], 0.04),
    "channel": (
        [[0, 0], [4, 0], [4, 1], [2.5, 1], [2.5, 0.4], [1.5, 0.4], [1.5, 1], [0, 1]],
        [],
        0.035,
    ),
    "plate_hole_off": (
        [[0, 0], [2, 0], [2, 1], [0, 1]],
        [_circle(0.7, 0.45, 0.23, 90, True)],
        0.025,
    ),
}


def regions() -> Iterator[tuple[str, engine.Region, float]]:
    for path in sorted(CASES.glob("*.geojson")):
        parsed = parse_region(json.loads(path.read_text()))
        yield path.stem, parsed.region, float(parsed.properties["h"])
    for name, (shell, holes, h) in EXTRA.items():
        yield name, engine.make_region([(shell, holes)]), h


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--regions", default="", help="comma-separated names (default: all)")
    parser.add_argument("--no-gmsh", action="store_true", help="skip gmsh")
    args = parser.parse_args(argv)
    chosen = {r for r in args.regions.split(",") if r}
    t0 = time.perf_counter()
    engine.warmup()
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"numba warm-up {time.perf_counter() - t0:.1f} s; load average before: {load}")
    print(HEADER)
    totals: dict[str, list[dict[str, float]]] = {"as meshed": [], "swap+ga": []}
    verdicts = []
    for name, region, h in regions():
        if chosen and name not in chosen:
            continue
        t = time.perf_counter()
        mesh, _ = engine.mesh_region(region, engine.SizingParams(h))
        seconds = time.perf_counter() - t
        meshed = figures(mesh)
        print(row(name, "as meshed", meshed, seconds), flush=True)
        out, seconds, rate = smooth(mesh, "ga", swap=True)
        piped = figures(out)
        print(row(name, "swap+ga", piped, seconds, rate), flush=True)
        totals["as meshed"].append(meshed)
        totals["swap+ga"].append(piped)
        if args.no_gmsh:
            continue
        t = time.perf_counter()
        ref = gmsh_mesh(region, h)
        if ref is None:
            continue
        g = figures(ref)
        print(row(name, "gmsh FD+opt", g, time.perf_counter() - t), flush=True)
        worst_ok, mean_ok = piped["rr_min"] >= g["rr_min"], piped["rr_mean"] >= g["rr_mean"]
        verdicts.append(
            f"{name:20s} worst {piped['rr_min']:.3f} vs {g['rr_min']:.3f} "
            f"{'ok' if worst_ok else 'BEHIND'}; mean {piped['rr_mean']:.4f} vs "
            f"{g['rr_mean']:.4f} {'ok' if mean_ok else 'BEHIND'}"
        )
    print("\n## Averages over the regions")
    for method, rows in totals.items():
        if not rows:
            continue
        a = {k: np.array([r[k] for r in rows]) for k in rows[0]}
        worst = a["rr_min"]
        print(
            f"{method:10s} worst rr: mean {worst.mean():.3f}, lowest {worst.min():.3f}; "
            f"mean rr {a['rr_mean'].mean():.4f}; min angle: mean {a['angle_min'].mean():.1f}, "
            f"lowest {a['angle_min'].min():.1f}; q>=.91 {a['q91'].mean():.2f}%"
        )
    if verdicts:
        print("\n## Default pipeline against gmsh FD+opt (radius ratio)")
        print("\n".join(verdicts))
    print(f"load average after: {', '.join(f'{v:.1f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
