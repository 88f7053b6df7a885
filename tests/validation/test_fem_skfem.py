"""FEM against an independent implementation (scikit-fem) on identical meshes, and the algebraic properties of K."""

import meshio
import numpy as np
import pytest
import tetgen

# scikit-fem is a test dependency (the ".[test]" extra): a missing one fails here, it is never skipped.
import skfem
from skfem.models.elasticity import lame_parameters, linear_elasticity

from tissuesim.fem.linear import LinearFEM
from tissuesim.mesh import models
from tissuesim.mesh.regions import bottom_nodes
from tissuesim.mesh.tetmesh import TetMesh, tet_signed_volumes

E, NU = 5500.0, 0.3


def cube_mesh(resolution: int = 400, switches: str = "pq1.4a2e-7Q") -> TetMesh:
    surface = models.cube(resolution)
    points, tets = tetgen.TetGen(surface.vertices, surface.triangles).tetrahedralize(switches=switches)[:2]
    return TetMesh(points, tets)


def liver_mesh(meshes_dir) -> TetMesh:
    # SOFA's liver2 volume (cm → m), a tet mesh nobody here wrote; orient any left-handed tets.
    data = meshio.read(meshes_dir / "sofa" / "liver2_tet.vtu")
    points, tets = data.points * 0.01, data.cells_dict["tetra"].astype(np.int64)
    negative = tet_signed_volumes(points, tets) < 0
    tets[negative] = tets[negative][:, [0, 2, 1, 3]]
    return TetMesh(points, tets)


def skfem_solution(mesh: TetMesh, forces: np.ndarray, fixed: np.ndarray):
    """scikit-fem's K and displacement for the same mesh, loads and fixed nodes."""
    basis = skfem.Basis(skfem.MeshTet(mesh.points.T, mesh.tets.T), skfem.ElementVector(skfem.ElementTetP1()))
    k = skfem.asm(linear_elasticity(*lame_parameters(E, NU)), basis)
    # Map skfem's dof numbering onto ours (node-major x, y, z) explicitly rather than assuming it.
    order = basis.nodal_dofs.T.ravel()  # our dof 3 i + c is skfem dof order[3 i + c]
    f = np.zeros(basis.N)
    f[order] = forces.ravel()
    u = skfem.solve(*skfem.condense(k, f, D=basis.nodal_dofs[:, fixed].ravel()))
    return k[order][:, order], u[order].reshape(-1, 3)


def loads(mesh: TetMesh) -> np.ndarray:
    """A pin-head-like point load on the top node plus a body-force-like load on every node [N]."""
    forces = np.zeros((mesh.node_count, 3))
    forces[:, 2] = -1e-4
    forces[np.argmax(mesh.points[:, 2])] += [0.2, -0.1, 0.5]
    return forces


@pytest.mark.parametrize("which", ["cube", "liver"])
def test_equals_scikit_fem(which, meshes_dir):
    mesh = cube_mesh() if which == "cube" else liver_mesh(meshes_dir)
    fixed = bottom_nodes(mesh.points)
    forces = loads(mesh)
    fem = LinearFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=fixed)
    k_ref, u_ref = skfem_solution(mesh, forces, fixed)
    assert abs(fem.stiffness - k_ref).max() <= 1e-12 * abs(k_ref).max()
    u = fem.solve(forces)
    assert np.abs(u - u_ref).max() <= 1e-9 * np.abs(u_ref).max()
    top = int(np.argmax(mesh.points[:, 2]))
    fast = fem.point_load_response([top], [[0.2, -0.1, 0.5]], output_nodes=np.arange(mesh.node_count))
    _, u_point = skfem_solution(mesh, np.eye(1, mesh.node_count, top).T @ [[0.2, -0.1, 0.5]], fixed)
    assert np.abs(fast - u_point).max() <= 1e-9 * np.abs(u_point).max()


def test_constrained_k_is_symmetric_positive_definite_and_free_k_has_six_rigid_modes():
    mesh = cube_mesh(150, "pq1.4Q")  # ~170 nodes: small enough for dense eigenvalues
    fem = LinearFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=bottom_nodes(mesh.points))
    reduced = fem.reduced_stiffness.toarray()
    assert np.abs(reduced - reduced.T).max() <= 1e-14 * np.abs(reduced).max()  # symmetric to round-off
    eigenvalues = np.linalg.eigvalsh(reduced)
    assert eigenvalues[0] > 1e-8 * eigenvalues[-1]  # positive definite, with margin
    free = np.linalg.eigvalsh(fem.stiffness.toarray())
    tiny = free < 1e-10 * free[-1]
    assert tiny.sum() == 6  # exactly the three translations and three rotations ...
    assert free[6] > 1e-6 * free[-1]  # ... and nothing else is soft
    # ... and they are the rigid motions: K annihilates them.
    x = mesh.points - mesh.points.mean(axis=0)
    for axis in np.eye(3):
        for mode in (np.tile(axis, (mesh.node_count, 1)), np.cross(axis, x)):
            assert np.abs(fem.stiffness @ mode.ravel()).max() <= 1e-12 * abs(fem.stiffness).max() * np.abs(mode).max()
