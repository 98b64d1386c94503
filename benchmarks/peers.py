"""gmsh, the peer mesher of the side-by-side benchmarks, run the same way by each of them.

A script describes its geometry and size fields in a ``build`` step; :func:`run_gmsh` does the
rest once: a fresh gmsh session, the Frontal-Delaunay algorithm (6), ``generate(2)`` (and an
optional ``optimize``) timed in wall and CPU seconds, and the triangles read back as a
counter-clockwise :class:`engine.Mesh`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import ModuleType

import numpy as np

from engine import Mesh

#: One meshing thread: the figures compare single-threaded meshers.
ONE_THREAD = ("-nt", "1")


@dataclass(frozen=True)
class GmshRun:
    """What :func:`run_gmsh` measured."""

    mesh: Mesh  #: the triangles, counter-clockwise
    seconds: float  #: wall seconds of generate (+ optimize)
    cpu: float  #: CPU seconds of the same, all threads of the process


def run_gmsh(
    build: Callable[[ModuleType], None],
    *,
    argv: Sequence[str] = ONE_THREAD,
    read_config: bool = True,
    optimize: str | None = None,
) -> GmshRun:
    """Mesh with gmsh in a fresh session: ``build(gmsh)`` adds the model (geometry,
    synchronised, and any size fields or options of its own), then Frontal-Delaunay
    ``generate(2)`` and ``optimize`` (e.g. ``"Relocate2D"``) are timed and the mesh read."""
    import gmsh

    gmsh.initialize(list(argv), readConfigFiles=read_config)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        build(gmsh)
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay
        t0, c0 = time.perf_counter(), time.process_time()
        gmsh.model.mesh.generate(2)
        if optimize is not None:
            gmsh.model.mesh.optimize(optimize)
        seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
        return GmshRun(gmsh_triangles(gmsh), seconds, cpu)
    finally:
        gmsh.finalize()


def gmsh_triangles(gmsh: ModuleType) -> Mesh:
    """The triangles of the current gmsh model as a :class:`engine.Mesh`, counter-clockwise.

    Node tags are mapped to 0-based rows in one vectorised step; gmsh may orient a surface's
    triangles either way, so clockwise ones are flipped.
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
