"""Sharp input corners: the smallest angle against the bound the input sets.

Prints, never asserts. Regions: wedges (a triangle with one ``theta`` corner, sides 1) and
five-spike stars with ``theta`` tips, theta from 3 to 40 degrees, a generated country-like
coastline (a random fractal ring), seeded random "wobbly" regions (``graded_bench.wobbly``:
input vertices closer than the size, at unequal distances on the two sides of a corner, short
segments beside long ones) and seeded random spikes (:func:`spike_cases`). For each: the
default pipeline (``engine.mesh_then_smooth``), gmsh Frontal-Delaunay + ``Relocate2D``
(``smooth_bench.gmsh_mesh``, when gmsh is installed: ``make .venv/.bench-installed``) and
Triangle ``pq30`` (when the ``triangle`` PyPI package is installed: ``pip install triangle``, a
benchmark-only extra) at the same size. The bound is
``min(smallest input corner, 30)``; columns are the smallest angle and worst radius ratio (2r/R).
Writes ``benchmarks/results/corners.json``. Run: ``python benchmarks/corners_bench.py
[--random N] [--spikes N]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from record import write_rows
from smooth_bench import gmsh_mesh

import engine
from engine.mesh import Mesh
from engine.quality import triangle_quality

THETAS = (3, 5, 10, 15, 20, 30, 40)


def wedge(theta: float) -> engine.Region:
    t = np.radians(theta)
    return engine.make_region([([[0, 0], [1, 0], [np.cos(t), np.sin(t)]], [])])


def star(theta: float, spikes: int = 5) -> engine.Region:
    """A star whose tips have interior angle ``theta`` (outer radius 1)."""
    half = np.pi / spikes  # angle between a tip and the next notch, seen from the centre
    t = np.radians(theta) / 2
    # Notch radius r so that the tip's half-angle is t: tan(t) = r sin(half) / (1 - r cos(half)).
    r = np.tan(t) / (np.sin(half) + np.tan(t) * np.cos(half))
    a = np.arange(2 * spikes) * half
    rad = np.where(np.arange(2 * spikes) % 2 == 0, 1.0, r)
    return engine.make_region([(np.c_[rad * np.cos(a), rad * np.sin(a)], [])])


def coastline(seed: int = 3, levels: int = 7) -> engine.Region:
    """A country-like ring: midpoint displacement of a hexagon, kept simple by shapely."""
    import shapely

    rng = np.random.default_rng(seed)
    ring = np.c_[np.cos(np.arange(6) * np.pi / 3), np.sin(np.arange(6) * np.pi / 3)]
    for level in range(levels):
        nxt = np.roll(ring, -1, axis=0)
        mid = 0.5 * (ring + nxt) + rng.normal(0, 0.25 * 0.55**level, ring.shape)
        ring = np.stack([ring, mid], axis=1).reshape(-1, 2)
    shape = shapely.make_valid(shapely.Polygon(ring))
    shape = max(shapely.get_parts(shape), key=lambda g: g.area).simplify(0.002)
    return engine.make_region([(np.asarray(shape.exterior.coords), [])])


def ring_corners(ring: np.ndarray) -> np.ndarray:
    """Interior angles (degrees) of a ring with the region on its left."""
    d_in = ring - np.roll(ring, 1, axis=0)
    d_out = np.roll(ring, -1, axis=0) - ring
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    return 180.0 - np.degrees(np.arctan2(cross, (d_in * d_out).sum(axis=1)))


def triangle_mesh(region: engine.Region, h: float) -> Mesh | None:
    """Triangle ``pq30`` (holes too), imported here: graded_bench imports this module."""
    from graded_bench import triangle_pq30

    return triangle_pq30(region, h)


def wobbly_cases(count: int) -> list[tuple[str, engine.Region, float]]:
    """The seeded random regions of graded_bench at its sizes."""
    from graded_bench import wobbly

    return [(f"wobbly {seed}", *wobbly(seed)) for seed in range(count)]


def spike_cases(count: int) -> list[tuple[str, engine.Region, float]]:
    """Seeded random spikes (``tests/engine/shapes.py``): a 5-45-degree corner whose legs turn
    away at input vertices 0.3-2.5 sizes from it, the size 0.1-0.2: the corner's first nodes
    sit at unequal distances on its legs."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests.engine.shapes import spike_ring

    rng = np.random.default_rng(7)
    out = []
    for i in range(count):
        theta, legs, size = rng.uniform(5, 45), rng.uniform(0.3, 2.5, 2), rng.uniform(0.1, 0.2)
        ring = spike_ring(theta, (legs[0], legs[1]), size)
        out.append((f"spike {i}", engine.make_region([(ring, [])]), size))
    return out


def ours(region: engine.Region, h: float) -> Mesh:
    params = engine.PipelineParams(engine.SizingParams(size=h))
    return engine.mesh_then_smooth(region, params, np.random.default_rng(0)).smoothed.mesh


SYSTEMS: dict[str, Callable[[engine.Region, float], Mesh | None]] = {
    "evomesh": ours,
    "gmsh FD+opt": gmsh_mesh,
    "triangle pq30": triangle_mesh,
}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=20, help="random wobbly regions")
    parser.add_argument("--spikes", type=int, default=20, help="random spikes")
    args = parser.parse_args(argv)
    cases: list[tuple[str, engine.Region, float]] = []
    cases += [(f"wedge {t}", wedge(t), 0.1) for t in THETAS]
    cases += [(f"star {t}", star(t), 0.1) for t in THETAS]
    cases.append(("coastline", coastline(), 0.05))
    cases += wobbly_cases(args.random)
    cases += spike_cases(args.spikes)
    rows: list[dict[str, Any]] = []
    print(f"{'case':12s} {'bound':>6s} {'system':14s} {'ang min':>8s} {'rr min':>7s} "
          f"{'rr mean':>8s} {'tris':>7s} {'s':>6s}")  # fmt: skip
    for name, region, h in cases:
        smallest = min(float(ring_corners(r).min()) for r in region.rings)
        bound = min(smallest, 30.0)
        for system, run in SYSTEMS.items():
            t0 = time.perf_counter()
            mesh = run(region, h)
            seconds = time.perf_counter() - t0
            if mesh is None:
                continue
            q = triangle_quality(mesh)
            row = {
                "case": name, "bound": round(bound, 2), "system": system,
                "min_angle": round(float(q.min_angle.min()), 2),
                "rr_min": round(float(q.radius_ratio.min()), 3),
                "rr_mean": round(float(q.radius_ratio.mean()), 4),
                "triangles": mesh.n_triangles, "seconds": round(seconds, 2),
            }  # fmt: skip
            rows.append(row)
            print(f"{name:12s} {bound:6.2f} {system:14s} {row['min_angle']:8.2f} "
                  f"{row['rr_min']:7.3f} {row['rr_mean']:8.4f} {mesh.n_triangles:7d} "
                  f"{seconds:6.2f}", flush=True)  # fmt: skip
    _summary(rows)
    write_rows(
        "corners",
        rows,
        title="Sharp input corners: smallest angle against min(smallest input corner, 30)",
        notes="Wedges and 5-spike stars with theta-degree tips at size 0.1, a generated "
        "coastline at 0.05, seeded wobbly regions of graded_bench (sizes 2-6 vertex spacings, "
        "holes included), seeded spikes (5-45 degrees, legs 0.3-2.5 sizes, sizes 0.1-0.2); "
        "evomesh = default mesh_then_smooth; gmsh = Frontal-Delaunay + "
        "Relocate2D; triangle = Triangle pq30 with the same area bound.",
    )


def _summary(rows: list[dict[str, Any]]) -> None:
    """On how many regions evomesh reaches the bound (within half a degree), and its worst
    radius ratio reaches each peer's."""
    by_case: dict[str, dict[str, dict[str, Any]]] = {}
    for r in rows:
        by_case.setdefault(r["case"], {})[r["system"]] = r
    ours_ = [systems["evomesh"] for systems in by_case.values()]
    reached = sum(r["min_angle"] >= r["bound"] - 0.5 for r in ours_)
    print(f"\nevomesh reaches the bound on {reached}/{len(ours_)}")
    for peer in ("gmsh FD+opt", "triangle pq30"):
        pairs = [(s["evomesh"], s[peer]) for s in by_case.values() if peer in s]
        at_least = sum(o["rr_min"] >= p["rr_min"] for o, p in pairs)
        print(f"worst radius ratio at least {peer}'s on {at_least}/{len(pairs)}")


if __name__ == "__main__":
    main()
