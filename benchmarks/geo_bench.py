"""Edge lengths on the ellipsoid of lon/lat regions meshed in metres: old projection vs pyproj.

Prints, never asserts. Each region is meshed (``engine.mesh_region``, no smoothing) at a size in
metres twice: in the hand-written equirectangular plane the service used before (its formula is
copied here, for comparison only) and in the plane :func:`service.geo.project_rings` chooses
(UTM zone or local azimuthal equidistant, via pyproj). Every mesh edge is then measured on the
WGS 84 ellipsoid (``pyproj.Geod``) after mapping the points back to lon/lat. Columns: edge length
min / mean / max over the size, the mean in the southern and northern tenth of the region over the
size (a projection that drifts with latitude shows here), the worst relative difference between
an edge's ellipsoidal and planar lengths, and the tolerance ``project_rings`` states.

Run: ``python benchmarks/geo_bench.py``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pyproj import Geod
from record import write_rows

import engine
from service.geo import project_rings, unwrap_parts

FloatArray = NDArray[np.float64]
GEOD = Geod(ellps="WGS84")
EARTH_RADIUS_M = 6_371_008.8  # the old projection's sphere

#: name -> (west, south, east, north) in degrees (east < west crosses the antimeridian), size (m).
REGIONS: dict[str, tuple[tuple[float, float, float, float], float]] = {
    "10x10 deg, 55-65 N": ((10.0, 55.0, 20.0, 65.0), 20_000.0),
    "10x10 deg, equator": ((-5.0, -5.0, 5.0, 5.0), 20_000.0),
    "20x10 deg, 38-48 S": ((-80.0, -48.0, -60.0, -38.0), 25_000.0),
    "2x1 deg, 60-61 N (UTM)": ((14.0, 60.0, 16.0, 61.0), 2_000.0),
    "4x4 deg across 180": ((178.0, -2.0, -178.0, 2.0), 10_000.0),
}


def old_equirectangular(
    ring: FloatArray,
) -> tuple[FloatArray, Callable[[FloatArray], FloatArray]]:
    """The service's former ``project_wgs84`` (tangent equirectangular plane at the mean vertex)."""
    lon0, lat0 = float(ring[:, 0].mean()), float(ring[:, 1].mean())
    k = np.cos(np.radians(lat0))
    xy = np.column_stack(
        [
            np.radians(ring[:, 0] - lon0) * EARTH_RADIUS_M * k,
            np.radians(ring[:, 1] - lat0) * EARTH_RADIUS_M,
        ]
    )

    def inverse(p: FloatArray) -> FloatArray:
        return np.column_stack(
            [
                lon0 + np.degrees(p[:, 0] / (EARTH_RADIUS_M * k)),
                lat0 + np.degrees(p[:, 1] / EARTH_RADIUS_M),
            ]
        )

    return xy, inverse


def edge_figures(mesh: engine.Mesh, lonlat: FloatArray, size: float) -> dict[str, float | int]:
    t = mesh.triangles
    e = np.unique(
        np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1), axis=0
    )
    a, b = lonlat[e[:, 0]], lonlat[e[:, 1]]
    true = np.asarray(GEOD.inv(a[:, 0], a[:, 1], b[:, 0], b[:, 1])[2])
    planar = np.hypot(*(mesh.points[e[:, 0]] - mesh.points[e[:, 1]]).T)
    lat = 0.5 * (a[:, 1] + b[:, 1])
    south, north = np.percentile(lat, [10, 90])
    return {
        "triangles": mesh.n_triangles,
        "min/size": round(float(true.min() / size), 3),
        "mean/size": round(float(true.mean() / size), 3),
        "max/size": round(float(true.max() / size), 3),
        "south mean/size": round(float(true[lat <= south].mean() / size), 3),
        "north mean/size": round(float(true[lat >= north].mean() / size), 3),
        "worst |geod/planar-1| %": round(float(100 * np.abs(true / planar - 1).max()), 3),
    }


def mesh_planar(rings: FloatArray, size: float) -> engine.Mesh:
    region = engine.make_region([(rings, [])])
    return engine.mesh_region(region, engine.SizingParams(size))[0]


def bench(name: str, bbox: tuple[float, float, float, float], size: float) -> list[dict[str, Any]]:
    w, s, e, n = bbox
    outer = np.array([[w, s], [e, s], [e, n], [w, n]], dtype=np.float64)
    rows: list[dict[str, Any]] = []
    # Old: straight in lon/lat, so densify the same way before projecting, for a fair comparison.
    proj = project_rings([(outer, [])], "EPSG:4326", densify=size)
    dense = proj.inverse(proj.parts[0][0])
    ((old_ring, _),) = unwrap_parts([(dense, [])])
    if np.ptp(outer[:, 0]) > 180.0:  # the old code read this ring literally: round the globe
        wrapped = np.ptp(outer[:, 0])
        rows.append({"region": name, "projection": f"old (wraps {wrapped:.0f} deg of longitude)"})
    else:
        xy, inverse = old_equirectangular(old_ring)
        t0 = time.perf_counter()
        mesh = mesh_planar(xy, size)
        figs = edge_figures(mesh, inverse(mesh.points), size)
        rows.append(
            {
                "region": name,
                "projection": "old equirectangular",
                **figs,
                "stated tolerance %": "",
                "seconds": round(time.perf_counter() - t0, 2),
            }
        )
    t0 = time.perf_counter()
    proj = project_rings([(outer, [])], "EPSG:4326", densify=size)
    mesh = mesh_planar(proj.parts[0][0], size)
    figs = edge_figures(mesh, proj.inverse(mesh.points), size)
    assert proj.mesh_crs is not None
    label = proj.mesh_crs.name.replace("Azimuthal equidistant centred on", "aeqd at")
    rows.append(
        {
            "region": name,
            "projection": label,
            **figs,
            "stated tolerance %": round(100 * proj.tolerance, 3),
            "seconds": round(time.perf_counter() - t0, 2),
        }
    )
    return rows


def projection_speed(n: int = 100_000) -> dict[str, Any]:
    """Time of project_rings and of the inverse on ``n`` vertices (a digitised boundary)."""
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    ring = np.column_stack([15.0 + 4.0 * np.cos(t), 60.0 + 2.0 * np.sin(t)])
    t0 = time.perf_counter()
    proj = project_rings([(ring, [])], "EPSG:4326")
    t1 = time.perf_counter()
    proj.inverse(proj.parts[0][0])
    t2 = time.perf_counter()
    return {"vertices": n, "project_rings s": round(t1 - t0, 3), "inverse s": round(t2 - t1, 3)}


def main() -> None:
    engine.warmup()
    rows = [row for name, (bbox, size) in REGIONS.items() for row in bench(name, bbox, size)]
    keys = list(rows[1])
    print(" | ".join(keys))
    for row in rows:
        print(" | ".join(str(row.get(k, "")) for k in keys))
    speed = projection_speed()
    print(
        f"projection of {speed['vertices']} vertices: {speed['project_rings s']} s, "
        f"inverse {speed['inverse s']} s"
    )
    notes = (
        "Edge lengths measured on the WGS 84 ellipsoid (pyproj.Geod) after mapping mesh points "
        "back to lon/lat; mesher only (engine.mesh_region). Old: the former hand-written "
        "equirectangular projection. New: service.geo.project_rings (pyproj). "
        f"project_rings on a {speed['vertices']}-vertex ring: {speed['project_rings s']} s."
    )
    path = write_rows(
        "geo", rows, title="Lon/lat regions: edge lengths on the ellipsoid", notes=notes
    )
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
