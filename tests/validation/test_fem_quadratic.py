"""Quadratic tets (tissuesim.fem.quadratic, the contact reference's element) against scikit-fem's P2 element on the
same mesh, the exact energy of a uniform strain, the rigid modes, and the cantilever."""

import numpy as np
import pytest

# scikit-fem is a test dependency (the ".[test]" extra): a missing one fails here, it is never skipped.
import skfem
from skfem.models.elasticity import lame_parameters, linear_elasticity

from tissuesim.fem.material import Material
from tissuesim.fem.quadratic import QuadraticFEM, quadratic_stiffness
from tissuesim.mesh.regions import nodes_below
from tissuesim.mesh.tetmesh import structured_box

from test_fem_skfem import cube_mesh

E, NU = 5500.0, 0.3


def bottom(points):
    return nodes_below(points, points[:, 2].min())


def test_equals_scikit_fem_p2():
    mesh = cube_mesh()
    fem = QuadraticFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=bottom)
    basis = skfem.Basis(skfem.MeshTet(mesh.points.T, mesh.tets.T), skfem.ElementVector(skfem.ElementTetP2()),
                        intorder=2)
    k = skfem.asm(linear_elasticity(*lame_parameters(E, NU)), basis)
    # our node order: corners, then our edges; map each to scikit-fem's dofs explicitly
    theirs = {tuple(sorted(e)): i for i, e in enumerate(basis.mesh.edges.T.tolist())}
    edge_index = np.array([theirs[tuple(e)] for e in fem.edges.tolist()])
    order = np.concatenate([basis.nodal_dofs.T, basis.edge_dofs[:, edge_index].T]).ravel()
    ours = quadratic_stiffness(mesh, Material(E, NU), fem.elements, fem.node_count)
    assert abs(ours - k[order][:, order]).max() <= 1e-12 * abs(k).max()
    forces = np.zeros((fem.node_count, 3))
    forces[:, 2] = -1e-5
    forces[np.argmax(fem.points[:, 2])] += [0.2, -0.1, 0.5]
    f = np.zeros(basis.N)
    f[order] = forces.ravel()
    fixed_dofs = (3 * bottom(fem.points)[:, None] + np.arange(3)).ravel()
    u_ref = skfem.solve(*skfem.condense(k, f, D=order[fixed_dofs]))[order].reshape(-1, 3)
    u = fem.solve(forces)
    assert np.abs(u - u_ref).max() <= 1e-9 * np.abs(u_ref).max()


def test_uniform_strain_energy_is_exact_and_rigid_modes_cost_nothing():
    mesh = cube_mesh()
    fem = QuadraticFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=bottom)
    x = fem.points
    stiffness = quadratic_stiffness(mesh, Material(E, NU), fem.elements, fem.node_count)
    strain = np.array([[1.0, 0.3, -0.2], [0.3, -0.5, 0.1], [-0.2, 0.1, 0.7]]) * 1e-3
    u = x @ strain.T
    voigt = np.array([strain[0, 0], strain[1, 1], strain[2, 2], 2 * strain[0, 1], 2 * strain[1, 2], 2 * strain[0, 2]])
    exact = mesh.volumes.sum() * voigt @ Material(E, NU).elasticity_matrix() @ voigt
    assert u.ravel() @ (stiffness @ u.ravel()) == pytest.approx(exact, rel=1e-10)
    rotation = np.cross([0.3, -0.2, 1.0], x)
    for rigid in (np.tile([1.0, -2.0, 0.5], (len(x), 1)), rotation):
        assert np.abs(stiffness @ rigid.ravel()).max() <= 1e-9 * abs(stiffness).max() * np.abs(rigid).max()


def test_cantilever_is_close_to_timoshenko_on_a_coarse_mesh():
    """Where linear tets give 0.22 and 0.50 of Timoshenko's tip deflection (h = 10, 5 mm), quadratic ones are within
    a few per cent."""
    length, width, height, load = 0.1, 0.01, 0.01, 1e-3
    ratios = []
    for h in (0.01, 0.005):
        mesh = structured_box((length, width, height), (round(length / h), round(width / h), round(height / h)))
        fem = QuadraticFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=lambda p: np.flatnonzero(p[:, 0] <= 1e-12))
        faces = mesh.boundary_triangles
        on_end = faces[np.all(mesh.points[faces][:, :, 0] >= length - 1e-12, axis=1)]
        p = mesh.points[on_end]
        area = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        weights = fem.traction_weights(on_end, area / area.sum())
        forces = np.zeros((fem.node_count, 3))
        forces[:, 2] = -load * weights
        u = fem.solve(forces)
        tip = -np.sum(u[:, 2] * weights)        # traction-weighted mean deflection of the end face
        inertia, shear = width * height**3 / 12.0, E / (2.0 * (1.0 + NU))
        timoshenko = load * length**3 / (3.0 * E * inertia) + load * length / (5.0 / 6.0 * shear * width * height)
        ratios.append(tip / timoshenko)
    # measured: 0.976, 0.989
    assert 0.95 < ratios[0] < ratios[1] < 1.0


def test_bad_input_is_refused():
    from tissuesim.errors import SolverError

    mesh = cube_mesh()
    with pytest.raises(SolverError, match="callable"):
        QuadraticFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=[0, 1, 2])
    fem = QuadraticFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=lambda p: p[:, 2] <= p[:, 2].min())
    forces = np.zeros((fem.node_count, 3))
    forces[0, 0] = np.nan
    with pytest.raises(SolverError, match="non-finite"):
        fem.solve(forces)
    face = mesh.boundary_triangles[:2]
    with pytest.raises(SolverError, match="traction_weights"):
        fem.traction_weights(face, [1.0])
