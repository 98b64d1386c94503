"""Mesher benchmark: evomesh's advancing front side by side with gmsh's Frontal-Delaunay.

Run with ``make bench`` (or ``.venv/bin/python benchmarks/mesh_bench.py``). For every public case
and a large unit square (>= 200,000 triangles) it meshes with

- evomesh: advancing front plus its constrained relaxation (the mesher as users get it with
  ``--no-swap --smooth none``), and the raw front alone (``relax=0``);
- gmsh, algorithm 6 (Frontal-Delaunay) with its default smoothing, on the *same size field*:
  evomesh's field is handed to gmsh as a background view wherever it is not uniform,

and prints triangles, seconds, triangles per second, min angle, min / mean radius ratio, and the
evomesh/gmsh throughput ratio. Then it measures the peak memory of a 1,000,000-triangle mesh in
a fresh process for each mesher. It prints; it asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from engine import Mesh, Region, SizingParams, make_region, mesh_region, triangle_quality  # noqa: E402
from engine.sizing import SizeField, build_size_field  # noqa: E402

CASES = ROOT / "tests" / "data" / "cases"
LARGE_H = 0.003  # unit square: about 257,000 triangles
MILLION_H = 0.00152  # unit square: about 1,000,000 triangles


def load_cases() -> list[tuple[str, Region, float]]:
    out = []
    for path in sorted(CASES.glob("*.geojson")):
        feature = json.loads(path.read_text())
        rings = feature["geometry"]["coordinates"]
        out.append((path.stem, make_region([(rings[0], rings[1:])]), feature["properties"]["h"]))
    square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    out.append(("unit_square_large", square, LARGE_H))
    return out


def gmsh_mesh(region: Region, field: SizeField, background: Mesh | None) -> tuple[Mesh, float]:
    """Mesh ``region`` with gmsh algorithm 6 on ``field`` (via ``background`` when graded)."""
    import gmsh

    gmsh.initialize(["-nt", "1"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("region")
        geo = gmsh.model.geo
        for part in region.parts:
            loops = []
            for ring in part.rings:
                sizes = field(ring)
                pts = [geo.addPoint(x, y, 0.0, h) for (x, y), h in zip(ring, sizes, strict=True)]
                lines = [geo.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
                loops.append(geo.addCurveLoop(lines))
            geo.addPlaneSurface(loops)
        geo.synchronize()
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.option.setNumber("Mesh.MeshSizeMax", field.size)
        if background is not None:
            # Evomesh's size field, sampled at the vertices of a background mesh.
            view = gmsh.view.add("size")
            tri = background.points[background.triangles]  # (m, 3, 2)
            h = field(background.points)[background.triangles]
            data = np.concatenate(
                [tri[:, :, 0], tri[:, :, 1], np.zeros((len(tri), 3)), h], axis=1
            ).ravel()
            gmsh.view.addListData(view, "ST", len(tri), data.tolist())
            fid = gmsh.model.mesh.field.add("PostView")
            gmsh.model.mesh.field.setNumber(fid, "ViewTag", view)
            gmsh.model.mesh.field.setAsBackgroundMesh(fid)
            gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
            gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
            gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        t0 = time.perf_counter()
        gmsh.model.mesh.generate(2)
        seconds = time.perf_counter() - t0
        tags, coords, _ = gmsh.model.mesh.getNodes()
        index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        _, nodes = gmsh.model.mesh.getElementsByType(2)
        triangles = index[nodes.astype(np.int64)].reshape(-1, 3)
    finally:
        gmsh.finalize()
    points = coords.reshape(-1, 3)[:, :2]
    mesh = Mesh(points, triangles)
    flip = mesh.areas < 0
    triangles[flip] = triangles[flip][:, ::-1]
    return Mesh(points, triangles), seconds


def figures(mesh: Mesh, seconds: float) -> dict[str, float]:
    q = triangle_quality(mesh)
    return {
        "triangles": mesh.n_triangles,
        "seconds": seconds,
        "tri_per_s": mesh.n_triangles / seconds,
        "min_angle": float(q.min_angle.min()),
        "min_rr": float(q.radius_ratio.min()),
        "mean_rr": float(q.radius_ratio.mean()),
        "below_30": float(np.mean(q.min_angle < 30.0)),
    }


def evomesh_mesh(region: Region, h: float, relax: int) -> tuple[Mesh, float]:
    t0 = time.perf_counter()
    mesh, _ = mesh_region(region, SizingParams(size=h), relax)
    return mesh, time.perf_counter() - t0


def row(name: str, who: str, f: dict[str, float], ratio: str = "") -> str:
    return (
        f"{name:18s} {who:22s} {f['triangles']:9d} {f['seconds']:8.3f} {f['tri_per_s']:10.0f} "
        f"{f['min_angle']:8.1f} {f['min_rr']:7.3f} {f['mean_rr']:8.4f} {100 * f['below_30']:7.2f} "
        f"{ratio}"
    )


def peak_memory(which: str) -> str:
    """Peak RSS of meshing the 1M-triangle unit square in a fresh process."""
    proc = subprocess.run(
        [sys.executable, __file__, "--memory-child", which],
        capture_output=True, text=True, check=True, timeout=1200,
    )  # fmt: skip
    return proc.stdout.strip().splitlines()[-1]


def memory_child(which: str) -> None:
    square = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [])])
    if which == "evomesh":
        mesh, seconds = evomesh_mesh(square, MILLION_H, 3)
    else:
        mesh, seconds = gmsh_mesh(square, build_size_field(square, SizingParams(MILLION_H)), None)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{which:8s} {mesh.n_triangles:9d} triangles {seconds:7.2f} s peak RSS {peak_mb:7.0f} MB")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--memory-child", choices=["evomesh", "gmsh"])
    parser.add_argument("--skip-memory", action="store_true")
    args = parser.parse_args()
    if args.memory_child:
        memory_child(args.memory_child)
        return
    warm = make_region([([[0, 0], [1, 0], [1, 1], [0, 1]], [[[0.4, 0.4], [0.6, 0.4], [0.5, 0.6]]])])
    evomesh_mesh(warm, 0.1, 3)  # compile (or load cached) numba kernels outside the timings
    print(
        f"{'case':18s} {'mesher':22s} {'triangles':>9s} {'seconds':>8s} {'tri/s':>10s} "
        f"{'min ang':>8s} {'min RR':>7s} {'mean RR':>8s} {'<30deg%':>7s} evomesh/gmsh tri/s"
    )
    for name, region, h in load_cases():
        raw = figures(*evomesh_mesh(region, h, 0))
        mesh, seconds = evomesh_mesh(region, h, 3)
        ours = figures(mesh, seconds)
        field = build_size_field(region, SizingParams(size=h))
        graded = len(field.feature_h) > 0
        theirs = figures(*gmsh_mesh(region, field, mesh if graded else None))
        ratio = ours["tri_per_s"] / theirs["tri_per_s"]
        print(row(name, "evomesh (front+relax)", ours, f"{ratio:.2f}x"))
        print(row(name, "evomesh raw front", raw))
        print(row(name, "gmsh frontal-Delaunay", theirs))

    if not args.skip_memory:
        print(f"\nPeak memory, unit square at h={MILLION_H:g} (about 1,000,000 triangles):")
        for which in ("evomesh", "gmsh"):
            print("  " + peak_memory(which))


if __name__ == "__main__":
    main()
