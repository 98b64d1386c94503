"""Smoothing benchmark: the smoothers side by side, and the full pipeline against gmsh.

Prints, never asserts. Two tables:

1. ``tests/data/poor/*.poor.json`` (valid meshes of the public cases with jittered interior
   nodes): none / laplacian / smart-laplacian / ga (paper parameters, default fitness) on the same
   connectivity (no swapping, so only the smoothers differ), plus ``swap+ga`` (what
   ``evomesh smooth`` does by default).
2. evomesh's own meshes of ``tests/data/cases/*.geojson`` (size ``h`` from each Feature): as
   meshed, after the default pipeline (swap + ga), and gmsh Frontal-Delaunay (``Mesh.Algorithm 6``
   with its ``Relocate2D`` optimiser) at the same size, when gmsh is installed (``make bench``
   installs it).

Columns: worst and mean radius ratio (2r/R), smallest angle, share of triangles with quality
>= 0.91, inverted triangles, seconds, node-GAs per second (one node-GA = population x generations
candidate evaluations). Run: ``python benchmarks/smooth_bench.py [--cases a,b] [--no-own]``;
``--only-throughput`` measures only the GA's node-GAs per second (``ga_throughput.json``).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import time
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from peers import run_gmsh
from record import write_rows

import engine
from engine.mesh import Mesh
from engine.quality import triangle_quality
from service.geojson import parse_region

ROOT = Path(__file__).resolve().parents[1]
POOR = ROOT / "tests" / "data" / "poor"
CASES = ROOT / "tests" / "data" / "cases"
HEADER = (
    f"{'case':20s} {'method':16s} {'rr min':>7s} {'rr mean':>8s} {'ang min':>8s} "
    f"{'q>=.91':>7s} {'inv':>4s} {'tris':>6s} {'s':>7s} {'nGA/s':>7s}"
)


def _quiet(stage: str, fraction: float) -> None:
    del stage, fraction


def _never() -> bool:
    return False


def figures(mesh: Mesh) -> dict[str, float]:
    q = triangle_quality(mesh)
    return {
        "rr_min": float(q.radius_ratio.min()),
        "rr_mean": float(q.radius_ratio.mean()),
        "angle_min": float(q.min_angle.min()),
        "q91": 100.0 * float(np.mean(q.quality >= 0.91)),
        "inverted": int(np.count_nonzero(q.area <= 0)),
        "triangles": mesh.n_triangles,
    }


def row(case: str, method: str, f: dict[str, float], seconds: float, rate: float = 0.0) -> str:
    rate_text = f"{rate:7.0f}" if rate else f"{'':>7s}"
    return (
        f"{case:20s} {method:16s} {f['rr_min']:7.3f} {f['rr_mean']:8.4f} {f['angle_min']:8.1f} "
        f"{f['q91']:6.1f}% {f['inverted']:4d} {f['triangles']:6d} {seconds:7.2f} {rate_text}"
    )


def smooth(mesh: Mesh, method: str, swap: bool) -> tuple[Mesh, float, float]:
    """Smooth with the default (paper) parameters; returns mesh, seconds, node-GAs per second."""
    params = engine.SmoothingParams(method=method)
    t0 = time.perf_counter()
    if swap:  # exactly what `evomesh smooth` runs: settle, swap, valence flips, smoother
        result = engine.smooth_mesh(mesh, params, swap=True, rng=np.random.default_rng(0))
        smoothed, history = result.smoothed.mesh, result.history
    else:
        out = engine.smoothing.smooth_points(mesh, params, np.random.default_rng(0), _quiet, _never)
        smoothed, history = mesh.with_points(out.points), out.history
    seconds = time.perf_counter() - t0
    evolved = sum(h.nodes_evolved for h in history) if method == "ga" else 0
    ga_seconds = sum(h.seconds for h in history)
    return smoothed, seconds, evolved / ga_seconds if evolved else 0.0


def throughput(repeats: int) -> float:
    """Node-GAs per second of one full GA sweep (paper parameters) on the largest poor mesh, on
    one thread and on all (best of ``repeats``, wall and CPU); writes ``ga_throughput.json``."""
    import numba

    doc = json.loads((POOR / "unit_square.poor.json").read_text())
    mesh = engine.validate_mesh(doc["points"], doc["triangles"])
    params = engine.SmoothingParams(max_sweeps=1, selection="all")
    print(
        "\n## GA throughput: one sweep over every interior node of unit_square.poor (8,000 nodes)"
    )
    rows: list[dict[str, Any]] = []
    threads = numba.get_num_threads()
    for n in sorted({1, threads}):
        numba.set_num_threads(n)
        wall, cpu, evolved = math.inf, math.inf, 0
        for _ in range(repeats):
            c0 = time.process_time()
            out = engine.smoothing.smooth_points(
                mesh, params, np.random.default_rng(0), _quiet, _never
            )
            cpu = min(cpu, time.process_time() - c0)
            wall, evolved = min(wall, out.history[0].seconds), out.history[0].nodes_evolved
        rows.append(
            {
                "threads": n,
                "node_gas": evolved,
                "wall_s": round(wall, 3),
                "per_s": round(evolved / wall),
                "cpu_s": round(cpu, 3),
                "per_cpu_s": round(evolved / cpu),
                "load": round(os.getloadavg()[0], 1),
            }
        )
        print(f"{n} thread(s), best of {repeats}: {evolved} node-GAs in {wall:.2f} s = "
              f"{evolved / wall:.0f} per s; {evolved / cpu:.0f} per CPU-second")  # fmt: skip
    numba.set_num_threads(threads)
    write_rows("ga_throughput", rows, title="GA node-GAs per second (paper parameters)",
               notes="python benchmarks/smooth_bench.py --only-throughput; one selection='all' "
               f"sweep of unit_square.poor, best of {repeats} (wall: the sweep; CPU: all threads "
               "of the process); load: the machine's 1-minute load average after")  # fmt: skip
    return max(row["per_s"] for row in rows)


def poor_table(names: list[str]) -> dict[str, dict[str, dict[str, float]]]:
    print("\n## Smoothers on the poor meshes (same connectivity; swap+ga = `evomesh smooth`)")
    print(HEADER)
    results: dict[str, dict[str, dict[str, float]]] = {}
    for name in names:
        doc = json.loads((POOR / f"{name}.poor.json").read_text())
        mesh = engine.validate_mesh(doc["points"], doc["triangles"])
        results[name] = {}
        for method, swap in [("none", False), ("laplacian", False), ("smart-laplacian", False),
                             ("ga", False), ("ga", True)]:  # fmt: skip
            out, seconds, rate = smooth(mesh, method, swap)
            label = f"swap+{method}" if swap else method
            results[name][label] = f = figures(out) | {"seconds": seconds, "rate": rate}
            print(row(name, label, f, seconds, rate), flush=True)
    return results


def gmsh_mesh(
    region: engine.Region, h: float, timing: dict[str, float] | None = None
) -> Mesh | None:
    """gmsh Frontal-Delaunay + ``Relocate2D`` at size ``h``; ``timing["seconds"]`` gets the time
    of generate + optimize alone (not the geometry set-up), ``timing["cpu"]`` its CPU time."""
    if importlib.util.find_spec("gmsh") is None:
        return None

    def build(gmsh: ModuleType) -> None:
        gmsh.model.add("case")
        geo = gmsh.model.geo
        for part in region.parts:
            loops = []
            for ring in part.rings:
                pts = [geo.addPoint(float(x), float(y), 0.0, h) for x, y in ring]
                lines = [geo.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
                loops.append(geo.addCurveLoop(lines))
            geo.addPlaneSurface(loops)
        geo.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)

    run = run_gmsh(build, argv=(), read_config=False, optimize="Relocate2D")
    if timing is not None:
        timing["seconds"], timing["cpu"] = run.seconds, run.cpu
    return run.mesh


def own_table(names: list[str]) -> dict[str, dict[str, dict[str, float]]]:
    print("\n## Full pipeline on evomesh's own meshes of the public cases, and gmsh")
    print(HEADER)
    results: dict[str, dict[str, dict[str, float]]] = {}
    for name in names:
        parsed = parse_region(json.loads((CASES / f"{name}.geojson").read_text()))
        h = float(parsed.properties["h"])
        t0 = time.perf_counter()
        mesh, _ = engine.mesh_region(parsed.region, engine.SizingParams(h))
        mesh_seconds = time.perf_counter() - t0
        results[name] = {"meshed": figures(mesh) | {"seconds": mesh_seconds}}
        print(row(name, "as meshed", results[name]["meshed"], mesh_seconds), flush=True)
        out, seconds, rate = smooth(mesh, "ga", swap=True)
        results[name]["swap+ga"] = f = figures(out) | {"seconds": seconds, "rate": rate}
        print(row(name, "swap+ga", f, seconds, rate), flush=True)
        t0 = time.perf_counter()
        ref = gmsh_mesh(parsed.region, h)
        if ref is not None:
            results[name]["gmsh"] = g = figures(ref) | {"seconds": time.perf_counter() - t0}
            print(row(name, "gmsh FD+opt", g, g["seconds"]), flush=True)
    return results


def verdicts(rate: float, poor: dict[str, Any], own: dict[str, Any]) -> None:
    print("\n## Targets")
    print(f"node-GAs per second (one sweep, all threads): {rate:.0f} "
          f"(target >= 15000 on 2 idle cores): {'ok' if rate >= 15000 else 'MISSED'}")  # fmt: skip
    for name, r in poor.items():
        ok = r["ga"]["rr_min"] >= r["smart-laplacian"]["rr_min"] and r["ga"]["inverted"] == 0
        print(f"poor {name:20s} ga rr min {r['ga']['rr_min']:.3f} vs smart-laplacian "
              f"{r['smart-laplacian']['rr_min']:.3f}: {'ok' if ok else 'MISSED'}")  # fmt: skip
    for name, r in own.items():
        f = r["swap+ga"]
        ok = f["angle_min"] >= 40 and f["rr_min"] >= 0.8 and f["q91"] >= 99.5
        line = (f"own  {name:20s} angle {f['angle_min']:.1f} rr {f['rr_min']:.3f} "
                f"q>=.91 {f['q91']:.2f}%: {'ok' if ok else 'MISSED'}")  # fmt: skip
        if "gmsh" in r:
            g = r["gmsh"]
            match = f["rr_min"] >= g["rr_min"] and f["rr_mean"] >= g["rr_mean"]
            line += (f"; vs gmsh rr min {g['rr_min']:.3f} mean {g['rr_mean']:.4f}: "
                     f"{'matches' if match else 'behind'}")  # fmt: skip
        print(line)


#: Extra pipeline cases: (public case, size): the 39k-triangle plate of issue 15.
LARGE = [("plate_hole", 0.015)]


def pipeline_table(names: list[str], selections: list[str], runs: int) -> list[dict[str, Any]]:
    """The default pipeline (``mesh_then_smooth``) against gmsh generate + optimize, best of
    ``runs`` each, in this process; one row per case and selection. Wall seconds and CPU
    seconds (``time.process_time``, all threads of the process): on a machine shared with
    other work the wall time mostly measures waiting for a core, the CPU time does not."""
    print(f"\n## Default pipeline vs gmsh FD + Relocate2D (best of {runs}, same run)")
    print(f"{'case':22s} {'sel':4s} {'tris':>6s} {'evomesh s':>9s} {'gmsh s':>7s} "
          f"{'ratio':>6s} {'cpu s':>6s} {'gmsh':>6s} {'ratio':>6s} {'rr min':>7s} {'gmsh':>6s} "
          f"{'rr mean':>8s} {'gmsh':>7s}  evolved/moved per sweep")  # fmt: skip
    rows: list[dict[str, Any]] = []
    cases = [(n, None) for n in names] + [(n, h) for n, h in LARGE if n in names]
    for name, size in cases:
        parsed = parse_region(json.loads((CASES / f"{name}.geojson").read_text()))
        h = float(size if size is not None else parsed.properties["h"])
        label = name if size is None else f"{name}@{h:g}"
        timing: dict[str, float] = {}
        ref, g_time, g_cpu = None, math.inf, math.inf
        for _ in range(runs):
            ref = gmsh_mesh(parsed.region, h, timing)
            g_time = min(g_time, timing.get("seconds", math.inf))
            g_cpu = min(g_cpu, timing.get("cpu", math.inf))
        for sel in selections:
            params = engine.PipelineParams(
                engine.SizingParams(h), smoothing=engine.SmoothingParams(selection=sel)
            )
            e_time, e_cpu, stages = math.inf, math.inf, {}
            for _ in range(runs):
                c0 = time.process_time()
                result = engine.mesh_then_smooth(parsed.region, params, np.random.default_rng(0))
                e_cpu = min(e_cpu, time.process_time() - c0)
                if result.timings["total"] < e_time:
                    e_time, stages = result.timings["total"], result.timings
            f = figures(result.smoothed.mesh)
            g = figures(ref) if ref is not None else {"rr_min": math.nan, "rr_mean": math.nan}
            sweeps = " ".join(f"{w.nodes_evolved}/{w.nodes_moved}" for w in result.history)
            r = {
                "case": label, "selection": sel, "triangles": f["triangles"],
                "evomesh_s": round(e_time, 3), "gmsh_s": round(g_time, 3),
                "ratio": round(e_time / g_time, 2), "evomesh_cpu_s": round(e_cpu, 3),
                "gmsh_cpu_s": round(g_cpu, 3), "cpu_ratio": round(e_cpu / g_cpu, 2),
                "rr_min": round(f["rr_min"], 4),
                "gmsh_rr_min": round(g["rr_min"], 4), "rr_mean": round(f["rr_mean"], 4),
                "gmsh_rr_mean": round(g["rr_mean"], 4),
                "evolved": sum(w.nodes_evolved for w in result.history),
                "moved": sum(w.nodes_moved for w in result.history),
                "sweeps": sweeps,
                **{f"{k}_s": round(v, 3) for k, v in stages.items() if k != "total"},
            }  # fmt: skip
            rows.append(r)
            print(f"{label:22s} {sel:4s} {r['triangles']:6d} {e_time:9.2f} {g_time:7.2f} "
                  f"{r['ratio']:6.2f} {e_cpu:6.2f} {g_cpu:6.2f} {r['cpu_ratio']:6.2f} "
                  f"{f['rr_min']:7.3f} {g['rr_min']:6.3f} {f['rr_mean']:8.4f} "
                  f"{g['rr_mean']:7.4f}  {sweeps}", flush=True)  # fmt: skip
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    names = sorted(p.name.removesuffix(".poor.json") for p in POOR.glob("*.poor.json"))
    parser.add_argument("--cases", default=",".join(names), help="comma-separated case names")
    parser.add_argument("--no-poor", action="store_true", help="skip the poor-mesh table")
    parser.add_argument("--no-own", action="store_true", help="skip the own-mesh table")
    parser.add_argument("--no-pipeline", action="store_true", help="skip the pipeline table")
    parser.add_argument("--only-pipeline", action="store_true", help="only the pipeline table")
    parser.add_argument("--selection", default="poor,all", help="selections for the pipeline")
    parser.add_argument("--runs", type=int, default=3, help="best of this many pipeline runs")
    parser.add_argument("--repeats", type=int, default=5, help="best of this many GA sweeps")
    parser.add_argument("--only-throughput", action="store_true", help="only GA throughput")
    args = parser.parse_args(argv)
    chosen = [c for c in args.cases.split(",") if c]
    t0 = time.perf_counter()
    engine.warmup()
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"numba warm-up {time.perf_counter() - t0:.1f} s; load average before: {load}")
    if args.only_throughput:
        throughput(args.repeats)
        return
    if not args.no_pipeline:
        selections = [s for s in args.selection.split(",") if s]
        rows = pipeline_table(chosen, selections, args.runs)
        write_rows("smooth", rows, title="Default pipeline vs gmsh FD + Relocate2D",
                   notes="python benchmarks/smooth_bench.py; seconds: best of "
                   f"{args.runs} in one process (evomesh: timings.total of mesh_then_smooth, "
                   "warm kernels; gmsh: generate + optimize); evolved/moved: node-GAs run and "
                   "nodes moved over all sweeps")  # fmt: skip
    if args.only_pipeline:
        return
    rate = throughput(args.repeats)
    poor = {} if args.no_poor else poor_table(chosen)
    own = {} if args.no_own else own_table(chosen)
    verdicts(rate, poor, own)
    print(f"load average after: {', '.join(f'{v:.1f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
