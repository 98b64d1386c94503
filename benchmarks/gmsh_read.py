"""Reading the mesh gmsh just made, for the side-by-side benchmarks."""

from __future__ import annotations

import gmsh
import numpy as np

from engine import Mesh


def gmsh_triangles() -> Mesh:
    """The triangles of the current gmsh model as a :class:`engine.Mesh`, counter-clockwise.

    Call it before ``gmsh.finalize()``. Node tags are mapped to 0-based rows in one vectorised
    step; gmsh may orient a surface's triangles either way, so clockwise ones are flipped.
    """
    tags, coords, _ = gmsh.model.mesh.getNodes()
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    _, nodes = gmsh.model.mesh.getElementsByType(2)
    triangles = index[nodes.astype(np.int64)].reshape(-1, 3)
    points = np.ascontiguousarray(coords.reshape(-1, 3)[:, :2])
    flip = Mesh(points, triangles).areas < 0
    triangles[flip] = triangles[flip][:, ::-1]
    return Mesh(points, triangles)
