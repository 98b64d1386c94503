"""A real client: a solver reads our MSH with meshio, finds the boundaries by their tag names and
solves Laplace's equation with scikit-fem on an annulus, against the exact solution."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import engine
from service.document import result_document
from service.formats import FORMATS, StoredResult

R, R0 = 1.0, 0.3


def _circle(r: float, n: int) -> list[list[float]]:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.c_[r * np.cos(t), r * np.sin(t)].tolist()


def _annulus_msh(path: Path) -> None:
    region = engine.make_region([(_circle(R, 256), [_circle(R0, 128)])])
    params = engine.PipelineParams(
        engine.SizingParams(0.04), smoothing=engine.SmoothingParams("laplacian")
    )
    result = engine.mesh_then_smooth(region, params, np.random.default_rng(0))
    doc = result_document(result, tags=engine.tag_mesh(result.smoothed.mesh, region))
    path.write_bytes(FORMATS["msh"].render(StoredResult(doc=doc), {}))


def test_laplace_on_an_annulus_read_from_msh_matches_the_exact_solution(tmp_path: Path) -> None:
    import meshio
    import skfem
    from skfem.models.poisson import laplace

    _annulus_msh(tmp_path / "annulus.msh")
    msh = meshio.read(tmp_path / "annulus.msh")
    groups = {name: int(tag) for name, (tag, dim) in msh.field_data.items() if dim == 1}
    lines = msh.get_cells_type("line")
    physical = msh.get_cell_data("gmsh:physical", "line")
    hole = np.unique(lines[physical == groups["hole-1"]])
    outer = np.unique(lines[physical == groups["outer"]])
    mesh = skfem.MeshTri(msh.points[:, :2].T.copy(), msh.get_cells_type("triangle").T.copy())
    basis = skfem.Basis(mesh, skfem.ElementTriP1())
    u = np.zeros(mesh.nvertices)
    u[hole] = 1.0
    fixed = np.concatenate([hole, outer])
    u = skfem.solve(*skfem.condense(skfem.asm(laplace, basis), np.zeros_like(u), x=u, D=fixed))
    r = np.hypot(*mesh.p)
    exact = np.log(r / R) / np.log(R0 / R)
    assert len(hole) > 50
    assert len(outer) > 100
    assert np.all(np.isclose(r[hole], R0, atol=1e-3))
    assert np.abs(u - exact).max() < 2e-3
