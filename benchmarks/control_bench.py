"""Mesh control benchmark: refinement layouts, evomesh's default pipeline against gmsh.

Each layout is the unit square at size H with one refinement of size S (a point, a line, a box)
growing at G, or at its own growth (``point-slow``: a point refinement growing at 1.05, its
``Refinement.growth``; gmsh's Threshold reaching H at (H - S) / (1.05 - 1)). evomesh runs its
default pipeline (front, swap, GA smoothing) with an ``engine.Refinement``; gmsh runs
Frontal-Delaunay (algorithm 6) with its default optimiser on the equivalent fields: Distance to
the geometry + Threshold (SizeMin S at distance 0 to SizeMax H at distance (H - S) / (G - 1)),
and a Box field inside the box. Printed and written to
``benchmarks/results/control_bench.json``: triangles, seconds, worst and mean radius ratio (2r/R)
and the evomesh/gmsh ratio of each.

Run: ``.venv/bin/python benchmarks/control_bench.py`` (needs ``make .venv/.bench-installed``).
"""

from __future__ import annotations

import time
from types import ModuleType
from typing import Any

import numpy as np
from peers import run_gmsh
from record import write_rows

import engine
from engine import Mesh, PipelineParams, Refinement, SizingParams, make_region, mesh_then_smooth
from engine.quality import triangle_quality

H, S, G = 0.1, 0.005, 1.2
SQUARE = [[0, 0], [1, 0], [1, 1], [0, 1]]
POINT = {"type": "Point", "coordinates": [0.5, 0.5]}
#: name -> (geometry, the refinement's own growth or None for the job's G)
LAYOUTS: dict[str, tuple[dict[str, Any], float | None]] = {
    "point": (POINT, None),
    "line": ({"type": "LineString", "coordinates": [[0.2, 0.3], [0.8, 0.7]]}, None),
    "box": (
        {
            "type": "Polygon",
            "coordinates": [[[0.3, 0.3], [0.6, 0.3], [0.6, 0.5], [0.3, 0.5], [0.3, 0.3]]],
        },
        None,
    ),
    "point-slow": (POINT, 1.05),
}


def ours(geometry: dict[str, Any], growth: float | None) -> tuple[Mesh, float]:
    refinement = Refinement(geometry, S, growth)
    params = PipelineParams(SizingParams(H, G, refinements=(refinement,)))
    t0 = time.perf_counter()
    result = mesh_then_smooth(make_region([(SQUARE, [])]), params, np.random.default_rng(0))
    return result.smoothed.mesh, time.perf_counter() - t0


def theirs(geometry: dict[str, Any], growth: float | None) -> tuple[Mesh, float]:
    def build(gmsh: ModuleType) -> None:
        geo = gmsh.model.geo
        corners = [geo.addPoint(x, y, 0) for x, y in SQUARE]
        lines = [geo.addLine(corners[i], corners[(i + 1) % 4]) for i in range(4)]
        geo.addPlaneSurface([geo.addCurveLoop(lines)])
        coords = np.asarray(geometry["coordinates"], dtype=float).reshape(-1, 2)
        pts = [geo.addPoint(x, y, 0, S) for x, y in coords]
        geo.synchronize()
        mesh_field = gmsh.model.mesh.field
        dist = mesh_field.add("Distance")
        if geometry["type"] == "Point":
            mesh_field.setNumbers(dist, "PointsList", pts)
        else:
            curves = [geo.addLine(pts[i], pts[i + 1]) for i in range(len(pts) - 1)]
            geo.synchronize()
            mesh_field.setNumbers(dist, "CurvesList", curves)
            mesh_field.setNumber(dist, "Sampling", int(np.ceil(2 / S)))
        thr = mesh_field.add("Threshold")
        mesh_field.setNumber(thr, "InField", dist)
        for key, value in (("SizeMin", S), ("SizeMax", H), ("DistMin", 0.0)):
            mesh_field.setNumber(thr, key, value)
        mesh_field.setNumber(thr, "DistMax", (H - S) / ((growth or G) - 1))
        fields = [thr]
        if geometry["type"] == "Polygon":
            box = mesh_field.add("Box")
            (x0, y0), (x1, y1) = coords.min(axis=0), coords.max(axis=0)
            for key, value in (("VIn", S), ("VOut", H), ("XMin", x0), ("XMax", x1)):
                mesh_field.setNumber(box, key, value)
            mesh_field.setNumber(box, "YMin", y0)
            mesh_field.setNumber(box, "YMax", y1)
            fields.append(box)
        least = mesh_field.add("Min")
        mesh_field.setNumbers(least, "FieldsList", fields)
        mesh_field.setAsBackgroundMesh(least)
        for key in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
            gmsh.option.setNumber(f"Mesh.{key}", 0)

    run = run_gmsh(build)
    return run.mesh, run.seconds


def figures(mesh: Mesh, seconds: float) -> dict[str, float]:
    q = triangle_quality(mesh)
    return {
        "triangles": mesh.n_triangles,
        "seconds": round(seconds, 3),
        "min_rr": round(float(q.radius_ratio.min()), 4),
        "mean_rr": round(float(q.radius_ratio.mean()), 4),
    }


def main() -> None:
    engine.warmup()
    rows = []
    print(f"{'layout':8s} {'mesher':8s} {'tris':>7s} {'s':>7s} {'min RR':>7s} {'mean RR':>8s}")
    for name, (geometry, growth) in LAYOUTS.items():
        a, b = figures(*ours(geometry, growth)), figures(*theirs(geometry, growth))
        for who, f in (("evomesh", a), ("gmsh", b)):
            print(
                f"{name:8s} {who:8s} {f['triangles']:7d} {f['seconds']:7.2f} "
                f"{f['min_rr']:7.3f} {f['mean_rr']:8.4f}"
            )
        row = {"layout": name}
        row |= {f"evomesh_{k}": v for k, v in a.items()}
        row |= {f"gmsh_{k}": v for k, v in b.items()}
        row["min_rr_ratio"] = round(a["min_rr"] / b["min_rr"], 3)
        row["mean_rr_ratio"] = round(a["mean_rr"] / b["mean_rr"], 4)
        rows.append(row)
    write_rows(
        "control_bench",
        rows,
        title="Refinement layouts: evomesh default pipeline vs gmsh Frontal-Delaunay",
        notes=f"unit square, size {H}, refinement size {S}, growth {G} (point-slow: the "
        "refinement's own growth 1.05); gmsh on Distance + "
        "Threshold (+ Box inside the box) fields; radius ratio 2r/R; ratios evomesh/gmsh; evomesh "
        "seconds include swapping and GA smoothing, gmsh's its meshing and default smoothing",
    )


if __name__ == "__main__":
    main()
