"""Graded bands: the mean radius ratio against gmsh at a matched triangle count.

Prints, never asserts. Where input vertices are closer than the size, the mesh grades up from
them and the graded band holds irregular nodes. Regions: the public cases
(``tests/data/cases/*.geojson``, size ``h`` from each Feature), narrow channels
(1-long rectangles, 100:1 at sizes 0.05 and 0.002, 30:1, 10:1) and seeded random wobbly regions
(star-shaped rings with many close vertices and up to two holes, the size several vertex
spacings). Systems: the default pipeline
(``engine.mesh_then_smooth``), gmsh Frontal-Delaunay + ``Relocate2D`` (when installed: ``make
.venv/.bench-installed``) with its size scaled until its triangle count is within 10% of ours
(at most six tries), and Triangle ``pq30`` (when the ``triangle`` package is installed) with the
same area bound. Columns: triangles, worst and mean radius ratio, smallest angle beside the
bound ``min(smallest input corner, 30)``, seconds and time over evomesh's. Writes
``benchmarks/results/graded.json``. Run: ``python benchmarks/graded_bench.py [--random N]
[--only a,b]``; ``--growth 1.2,1.1,1.05`` runs the random set alone at each growth (gmsh
matched at each) and writes ``benchmarks/results/graded_growth.json``; ``--same-field`` has
gmsh mesh the random set on evomesh's own size field (``graded_same_field.json``);
``--objectives`` runs the random set under each GA fitness and selection of
:data:`OBJECTIVES` (``graded_objectives.json``).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from corners_bench import ring_corners
from record import write_rows
from smooth_bench import gmsh_mesh

import engine
from engine.mesh import Mesh
from engine.quality import triangle_quality
from service.geojson import parse_region

CASES = Path(__file__).resolve().parents[1] / "tests" / "data" / "cases"
#: gmsh's count must come within this share of ours.
MATCH = 0.10


def channel(ratio: float) -> engine.Region:
    return engine.make_region([([[0, 0], [1, 0], [1, 1 / ratio], [0, 1 / ratio]], [])])


def wobbly(seed: int) -> tuple[engine.Region, float]:
    """A star-shaped ring of 40-160 vertices with radial noise, up to two polygonal holes, and
    a size two to six vertex spacings: the field grades up from the close vertices."""
    import shapely

    rng = np.random.default_rng(seed)
    n = int(rng.integers(40, 160))
    a = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = (
        1.0
        + 0.25 * np.sin(int(rng.integers(2, 6)) * a + rng.uniform(0, 6))
        + rng.normal(0, 0.03, n)
    )
    outer = np.c_[r * np.cos(a), r * np.sin(a)]
    shell = shapely.Polygon(outer)
    holes: list[np.ndarray] = []
    for _ in range(int(rng.integers(0, 3))):
        k = int(rng.integers(5, 30))
        c = rng.uniform(-0.4, 0.4, 2)
        t = np.linspace(2 * np.pi, 0, k, endpoint=False)  # clockwise
        rad = rng.uniform(0.08, 0.2) * (1 + rng.normal(0, 0.05, k))
        hole = c + np.c_[rad * np.cos(t), rad * np.sin(t)]
        poly = shapely.Polygon(hole)
        if shell.buffer(-0.1).contains(poly) and all(
            poly.distance(shapely.Polygon(h)) > 0.05 for h in holes
        ):
            holes.append(hole)
    spacing = float(np.median(np.hypot(*np.diff(outer, axis=0).T)))
    return engine.make_region([(outer, holes)]), spacing * float(rng.uniform(2.0, 6.0))


def cases(random: int) -> Iterator[tuple[str, str, engine.Region, float]]:
    for path in sorted(CASES.glob("*.geojson")):
        parsed = parse_region(json.loads(path.read_text()))
        yield "public", path.stem, parsed.region, float(parsed.properties["h"])
    for ratio, h in ((100, 0.05), (100, 0.002), (30, 0.05), (10, 0.02)):
        yield "channel", f"channel {ratio}:1 h{h:g}", channel(ratio), h
    for seed in range(random):
        region, h = wobbly(seed)
        yield "random", f"wobbly {seed}", region, h


def ours(
    region: engine.Region,
    h: float,
    growth: float = 1.2,
    smoothing: engine.SmoothingParams | None = None,
) -> Mesh:
    params = engine.PipelineParams(
        engine.SizingParams(size=h, growth=growth),
        smoothing=smoothing or engine.SmoothingParams(),
    )
    return engine.mesh_then_smooth(region, params, np.random.default_rng(0)).smoothed.mesh


def gmsh_matched(
    region: engine.Region, h: float, target: int, timing: dict[str, float]
) -> Mesh | None:
    """gmsh at a size scaled until its count is within :data:`MATCH` of ``target``: the count
    goes as ``h^-p``, ``p`` 2 at first and then measured from the last two tries (a graded
    mesh's count answers the size more weakly than ``h^-2``)."""
    mesh, power, last = gmsh_mesh(region, h, timing), 2.0, None
    for _ in range(6):
        if mesh is None or abs(mesh.n_triangles - target) <= MATCH * target:
            break
        if last is not None and last[1] != mesh.n_triangles:
            power = float(np.clip(np.log(mesh.n_triangles / last[1]) / np.log(last[0] / h), 0.5, 4))
        last = (h, mesh.n_triangles)
        h *= float((mesh.n_triangles / target) ** (1.0 / power))
        mesh = gmsh_mesh(region, h, timing)
    return mesh


def triangle_pq30(region: engine.Region, h: float) -> Mesh | None:
    """Triangle ``pq30`` with the area bound of an equilateral triangle of side ``h``."""
    try:
        import shapely
        import triangle
    except ImportError:
        return None
    rings = [np.asarray(r, dtype=np.float64) for r in region.rings]
    offsets = np.cumsum([0] + [len(r) for r in rings])
    seg = np.concatenate(
        [
            o + np.c_[np.arange(len(r)), (np.arange(len(r)) + 1) % len(r)]
            for o, r in zip(offsets, rings, strict=False)
        ]
    )
    holes = [
        np.asarray(shapely.Polygon(r).representative_point().coords[0])
        for part in region.parts
        for r in part.holes
    ]
    data: dict[str, Any] = {"vertices": np.concatenate(rings), "segments": seg}
    if holes:
        data["holes"] = np.asarray(holes)
    out = triangle.triangulate(data, f"pq30a{0.433 * h * h:.12f}")
    return Mesh(np.asarray(out["vertices"]), np.asarray(out["triangles"], dtype=np.int64))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=20, help="random wobbly regions")
    parser.add_argument("--only", default="", help="comma-separated case names")
    parser.add_argument(
        "--growth", default="", help="comma-separated growths: the random set at each alone"
    )
    parser.add_argument(
        "--same-field", action="store_true", help="the random set, gmsh on evomesh's size field"
    )
    parser.add_argument(
        "--objectives", action="store_true", help="the random set under each smoother objective"
    )
    args = parser.parse_args(argv)
    chosen = {c for c in args.only.split(",") if c}
    engine.warmup()
    if args.growth:
        growth_sweep([float(g) for g in args.growth.split(",")], args.random)
        return
    if args.same_field:
        same_field(args.random)
        return
    if args.objectives:
        objectives(args.random)
        return
    # (region, size, evomesh's count, timing): timing["seconds"], when set, replaces wall time.
    systems: dict[str, Callable[[engine.Region, float, int, dict[str, float]], Mesh | None]] = {
        "evomesh": lambda region, h, _, __: ours(region, h),
        "gmsh FD+opt": gmsh_matched,
        "triangle pq30": lambda region, h, _, __: triangle_pq30(region, h),
    }
    rows: list[dict[str, Any]] = []
    print(f"{'case':16s} {'bound':>6s} {'system':14s} {'tris':>7s} {'rr min':>7s} "
          f"{'rr mean':>8s} {'ang min':>8s} {'s':>6s} {'x ours':>7s}")  # fmt: skip
    for group, name, region, h in cases(args.random):
        if chosen and name not in chosen:
            continue
        bound = min(min(float(ring_corners(np.asarray(r)).min()) for r in region.rings), 30.0)
        count, base = 0, 0.0
        for system, run in systems.items():
            t0, timing = time.perf_counter(), {}
            mesh = run(region, h, count, timing)
            seconds = timing.get("seconds", time.perf_counter() - t0)
            if mesh is None:
                continue
            if system == "evomesh":
                count, base = mesh.n_triangles, seconds
            q = triangle_quality(mesh)
            row = {
                "group": group, "case": name, "bound": round(bound, 2), "system": system,
                "triangles": mesh.n_triangles,
                "rr_min": round(float(q.radius_ratio.min()), 3),
                "rr_mean": round(float(q.radius_ratio.mean()), 4),
                "min_angle": round(float(q.min_angle.min()), 2),
                "seconds": round(seconds, 3), "time_ratio": round(seconds / max(base, 1e-9), 2),
            }  # fmt: skip
            rows.append(row)
            print(f"{name:16s} {bound:6.2f} {system:14s} {mesh.n_triangles:7d} "
                  f"{row['rr_min']:7.3f} {row['rr_mean']:8.4f} {row['min_angle']:8.2f} "
                  f"{seconds:6.2f} {row['time_ratio']:7.2f}", flush=True)  # fmt: skip
    _summary(rows)
    write_rows(
        "graded",
        rows,
        title="Graded bands: mean radius ratio against gmsh at a matched triangle count",
        notes="Public cases at their h, 1-long channels 100:1 at 0.05 and 0.002, 30:1 at 0.05, "
        "10:1 at 0.02, seeded wobbly regions (sizes 2-6 vertex spacings); evomesh = default "
        "mesh_then_smooth; gmsh = Frontal-Delaunay + Relocate2D, its size scaled until its count "
        "is within 10% of evomesh's (seconds: its last run's generate + optimise); triangle = "
        "Triangle pq30 with the same area bound; time_ratio = seconds over evomesh's.",
    )


def growth_sweep(growths: list[float], random: int) -> None:
    """The random wobbly regions at each growth, gmsh matched to each count: whether a gentler
    grading (more triangles, each graded band nearer uniform) brings the mean to gmsh's, which
    refines with it. Writes ``benchmarks/results/graded_growth.json``."""
    rows: list[dict[str, Any]] = []
    print(f"{'case':10s} {'growth':>6s} {'tris':>6s} {'rr mean':>8s} {'rr min':>7s} "
          f"{'gmsh tris':>9s} {'rr mean':>8s} {'rr min':>7s}")  # fmt: skip
    for seed in range(random):
        region, h = wobbly(seed)
        for growth in growths:
            mesh = ours(region, h, growth)
            ref = gmsh_matched(region, h, mesh.n_triangles, {})
            if ref is None:
                return
            q, g = triangle_quality(mesh).radius_ratio, triangle_quality(ref).radius_ratio
            row = {
                "case": f"wobbly {seed}", "growth": growth, "triangles": mesh.n_triangles,
                "rr_mean": round(float(q.mean()), 4), "rr_min": round(float(q.min()), 3),
                "gmsh_triangles": ref.n_triangles, "gmsh_rr_mean": round(float(g.mean()), 4),
                "gmsh_rr_min": round(float(g.min()), 3),
            }  # fmt: skip
            rows.append(row)
            print(f"{row['case']:10s} {growth:6.2f} {mesh.n_triangles:6d} {row['rr_mean']:8.4f} "
                  f"{row['rr_min']:7.3f} {ref.n_triangles:9d} {row['gmsh_rr_mean']:8.4f} "
                  f"{row['gmsh_rr_min']:7.3f}", flush=True)  # fmt: skip
    for growth in growths:
        at = [r for r in rows if r["growth"] == growth]
        wins = sum(r["rr_mean"] >= r["gmsh_rr_mean"] for r in at)
        gap = float(np.mean([r["gmsh_rr_mean"] - r["rr_mean"] for r in at]))
        print(f"growth {growth}: mean at least gmsh's on {wins}/{len(at)}, mean gap {gap:.4f}")
    write_rows(
        "graded_growth",
        rows,
        title="Graded bands: the random regions' mean radius ratio against gmsh by growth",
        notes="Seeded wobbly regions of graded_bench.py at their sizes; evomesh = default "
        "mesh_then_smooth with the growth given; gmsh = Frontal-Delaunay + Relocate2D at a size "
        "scaled until its count is within 10% of evomesh's at that growth.",
    )


def same_field(random: int) -> None:
    """The random wobbly regions meshed by gmsh FD + ``Relocate2D`` on evomesh's own size field
    (``mesh_bench.gmsh_mesh``), then also swapped and smoothed by evomesh: whether the mean is
    lost in the layout of the graded band or in the size field. Writes
    ``benchmarks/results/graded_same_field.json``."""
    from mesh_bench import gmsh_mesh as gmsh_on_field

    from engine.sizing import build_size_field

    rows: list[dict[str, Any]] = []
    print(f"{'case':10s} {'system':36s} {'tris':>6s} {'rr mean':>8s} {'rr min':>7s}")
    for seed in range(random):
        region, h = wobbly(seed)
        sizing = engine.SizingParams(size=h)
        field = build_size_field(region, sizing)
        background, _ = engine.mesh_region(region, sizing)
        theirs, _ = gmsh_on_field(region, field, background, optimize="Relocate2D")
        meshes = {
            "evomesh": ours(region, h),
            "gmsh same field": theirs,
            "gmsh same field + evomesh smoothing": engine.smooth_mesh(
                theirs, engine.SmoothingParams(), rng=np.random.default_rng(0)
            ).smoothed.mesh,
        }
        for system, mesh in meshes.items():
            q = triangle_quality(mesh).radius_ratio
            row = {
                "case": f"wobbly {seed}", "system": system, "triangles": mesh.n_triangles,
                "rr_mean": round(float(q.mean()), 4), "rr_min": round(float(q.min()), 3),
            }  # fmt: skip
            rows.append(row)
            print(f"{row['case']:10s} {system:36s} {mesh.n_triangles:6d} {row['rr_mean']:8.4f} "
                  f"{row['rr_min']:7.3f}", flush=True)  # fmt: skip
    mean = {(r["case"], r["system"]): r["rr_mean"] for r in rows}
    for system in list(meshes)[1:]:
        wins = sum(mean[case, "evomesh"] >= mean[case, s] for case, s in mean if s == system)
        print(f"evomesh's mean at least {system}'s on {wins}/{random}")
    write_rows(
        "graded_same_field",
        rows,
        title="Graded bands: the random regions with gmsh on evomesh's own size field",
        notes="Seeded wobbly regions of graded_bench.py at their sizes; evomesh = default "
        "mesh_then_smooth; gmsh same field = Frontal-Delaunay + Relocate2D on evomesh's size "
        "field (a background view, as in mesh_bench.py); + evomesh smoothing = that mesh then "
        "swapped and smoothed by evomesh's defaults (engine.smooth_mesh).",
    )


#: The smoother objectives compared: (GA fitness, GA selection); the first is the default.
OBJECTIVES = (("capped", "poor"), ("combined", "poor"), ("worst", "poor"), ("capped", "all"))


def objectives(random: int) -> None:
    """The random wobbly regions under each smoother objective of :data:`OBJECTIVES`, gmsh
    matched to the count (the same for all: smoothing keeps the connectivity's size): whether
    an objective that gives less of the mean for the worst brings the mean to gmsh's. Writes
    ``benchmarks/results/graded_objectives.json``."""
    rows: list[dict[str, Any]] = []
    print(f"{'case':10s} {'objective':16s} {'tris':>6s} {'rr mean':>8s} {'rr min':>7s} "
          f"{'gmsh mean':>9s}")  # fmt: skip
    for seed in range(random):
        region, h = wobbly(seed)
        reference: Mesh | None = None
        for fitness, selection in OBJECTIVES:
            smoothing = engine.SmoothingParams(fitness=fitness, selection=selection)
            mesh = ours(region, h, smoothing=smoothing)
            reference = reference or gmsh_matched(region, h, mesh.n_triangles, {})
            if reference is None:
                return
            q = triangle_quality(mesh).radius_ratio
            g = triangle_quality(reference).radius_ratio
            row = {
                "case": f"wobbly {seed}", "objective": f"{fitness}/{selection}",
                "triangles": mesh.n_triangles, "rr_mean": round(float(q.mean()), 4),
                "rr_min": round(float(q.min()), 3), "gmsh_rr_mean": round(float(g.mean()), 4),
            }  # fmt: skip
            rows.append(row)
            print(f"{row['case']:10s} {row['objective']:16s} {mesh.n_triangles:6d} "
                  f"{row['rr_mean']:8.4f} {row['rr_min']:7.3f} {row['gmsh_rr_mean']:9.4f}",
                  flush=True)  # fmt: skip
    default = {r["case"]: r for r in rows if r["objective"] == "/".join(OBJECTIVES[0])}
    for fitness, selection in OBJECTIVES:
        at = [r for r in rows if r["objective"] == f"{fitness}/{selection}"]
        wins = sum(r["rr_mean"] >= r["gmsh_rr_mean"] for r in at)
        gap = float(np.mean([r["gmsh_rr_mean"] - r["rr_mean"] for r in at]))
        kept = sum(r["rr_min"] >= default[r["case"]]["rr_min"] for r in at)
        print(f"{fitness}/{selection}: mean at least gmsh's on {wins}/{len(at)}, mean gap "
              f"{gap:.4f}, worst at least the default's on {kept}/{len(at)}")  # fmt: skip
    write_rows(
        "graded_objectives",
        rows,
        title="Graded bands: the random regions' mean radius ratio by smoother objective",
        notes="Seeded wobbly regions of graded_bench.py at their sizes; evomesh = "
        "mesh_then_smooth with the GA fitness and selection given (capped/poor is the default); "
        "gmsh = Frontal-Delaunay + Relocate2D at a size scaled until its count is within 10% of "
        "evomesh's.",
    )


def _summary(rows: list[dict[str, Any]]) -> None:
    """Per group: on how many regions the pipeline's mean and worst reach gmsh's."""
    print("\n## evomesh against gmsh FD+opt (matched count)")
    by_case: dict[str, dict[str, dict[str, Any]]] = {}
    for r in rows:
        by_case.setdefault(r["case"], {})[r["system"]] = r
    groups: dict[str, list[tuple[bool, bool]]] = {}
    for systems in by_case.values():
        if "gmsh FD+opt" not in systems:
            continue
        ours_, ref = systems["evomesh"], systems["gmsh FD+opt"]
        groups.setdefault(ours_["group"], []).append(
            (ours_["rr_mean"] >= ref["rr_mean"], ours_["rr_min"] >= ref["rr_min"])
        )
    for group, verdicts in groups.items():
        mean_ok = sum(m for m, _ in verdicts)
        worst_ok = sum(w for _, w in verdicts)
        print(f"{group:8s} mean at least gmsh's on {mean_ok}/{len(verdicts)}, "
              f"worst on {worst_ok}/{len(verdicts)}")  # fmt: skip


if __name__ == "__main__":
    main()
