"""Random valid triangle meshes for property tests, independent of the mesher.

A mesh is a structured grid over a rectangle with a random diagonal in each cell and random cells
removed (holes, notches, pinched corners, several components), its interior nodes jittered as far
as validity allows, then mapped by a random affine map (rotation, stretch, shear) so triangles
come in every shape.
"""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from engine.mesh import Mesh, triangle_areas, validate_mesh


def random_mesh(seed: int, max_cells: int = 9, *, affine: bool = True) -> Mesh:
    """A random valid mesh; the same ``seed`` always gives the same mesh.

    ``affine=False`` skips the final stretch and shear (shapes stay close to right triangles).
    """
    rng = np.random.default_rng(seed)
    nx, ny = (int(v) for v in rng.integers(2, max_cells + 1, size=2))
    xs = np.cumsum(np.r_[0.0, rng.uniform(0.5, 1.5, nx)])
    ys = np.cumsum(np.r_[0.0, rng.uniform(0.5, 1.5, ny)])
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    points = np.c_[gx.ravel(), gy.ravel()]

    def vid(i: int, j: int) -> int:
        return i * (ny + 1) + j

    keep = rng.random((nx, ny)) >= rng.uniform(0.0, 0.3)
    keep[rng.integers(nx), rng.integers(ny)] = True
    tris = []
    for i in range(nx):
        for j in range(ny):
            if not keep[i, j]:
                continue
            a, b, c, d = vid(i, j), vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1)
            if rng.random() < 0.5:
                tris += [[a, b, c], [a, c, d]]
            else:
                tris += [[a, b, d], [b, c, d]]
    tri = np.array(tris, dtype=np.int64)
    used = np.unique(tri)
    renumber = np.full(len(points), -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    points, tri = points[used], renumber[tri]
    mesh = Mesh(points, tri)
    jitter = rng.uniform(-1.0, 1.0, points.shape) * rng.uniform(0.0, 0.45)
    jitter[mesh.boundary_nodes] = 0.0
    smallest = float(min(np.diff(xs).min(), np.diff(ys).min()))
    for _ in range(60):
        moved = points + jitter * smallest
        if triangle_areas(moved, tri).min() > 0.05 * smallest**2:
            points = moved
            break
        jitter *= 0.8
    angle = rng.uniform(0.0, 2.0 * np.pi)
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    stretch = np.diag(rng.uniform(0.3, 3.0, 2))
    shear = np.array([[1.0, rng.uniform(-0.8, 0.8)], [0.0, 1.0]])
    linear = rot @ stretch @ shear  # determinant > 0: orientation and validity are kept
    if affine:
        points = points @ linear.T + rng.uniform(-100.0, 100.0, 2)
    return validate_mesh(points, tri)


def meshes(max_cells: int = 9) -> st.SearchStrategy[Mesh]:
    """Hypothesis strategy drawing :func:`random_mesh` by seed (so failures shrink to a seed)."""
    return st.integers(0, 2**32 - 1).map(lambda seed: random_mesh(seed, max_cells))
