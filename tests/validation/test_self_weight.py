"""Self-weight against what nobody here wrote: the analytic column, scikit-fem's body-force load and solution, and
the fine FEM on the models.

A column of height H fixed at its base, with ν = 0 (so the fixed base does not constrain a lateral contraction), under
its weight: σ_zz = −ρ g (H − z), u_z(z) = −ρ g (H z − z²/2)/E, so u_z(H) = −ρ g H²/(2E), and u_x = u_y = 0.
"""

import numpy as np
import pytest
import skfem
from skfem.models.elasticity import lame_parameters, linear_elasticity

from tissuesim import HybridMesh, SurfaceMesh, make_solver
from tissuesim.fem.assembly import body_force
from tissuesim.fem.linear import LinearFEM
from tissuesim.mesh import models
from tissuesim.mesh.tetmesh import structured_box
from tissuesim.solvers import method_names

E, RHO, GRAVITY = 5500.0, 1000.0, 9.81
H, W = 0.1, 0.02        # the column's height and width [m]
G = (0.0, 0.0, -GRAVITY)


def column_mesh(divisions):
    return structured_box([W, W, H], divisions, origin=(-W / 2, -W / 2, 0.0))


def analytic_uz(z):
    return -RHO * GRAVITY * (H * z - 0.5 * z * z) / E


def column_solution(divisions, poisson_ratio=0.0):
    mesh = column_mesh(divisions)
    base = np.flatnonzero(mesh.points[:, 2] < 1e-12)
    fem = LinearFEM(mesh, youngs_modulus=E, poisson_ratio=poisson_ratio, fixed=base)
    return mesh, fem, fem.solve(body_force(mesh, RHO, G))


def test_the_column_converges_to_the_analytic_self_weight():
    """Kuhn-split hex columns 20 mm × 20 mm × 100 mm, 4 to 24 layers: the top's mean u_z is within 0.1 % of
    ρgH²/(2E) on every mesh; the largest nodal error of u over the column falls at least 1.7x per halving of h
    (first order: the Kuhn split's asymmetry bends the column slightly, its lateral displacement the larger part),
    to below 3.5 % of u_z(H) on the finest (measured 20.7, 13.6, 5.9, 3.1 %)."""
    exact = RHO * GRAVITY * H * H / (2 * E)
    errors = []
    for n in (1, 2, 4, 6):
        mesh, _, u = column_solution((n, n, 4 * n))
        z = mesh.points[:, 2]
        top = z > H - 1e-12
        assert abs(-u[top, 2].mean() / exact - 1.0) < 1e-3, n
        expected = np.zeros_like(u)
        expected[:, 2] = analytic_uz(z)
        errors.append(np.abs(u - expected).max() / exact)
    # h: 1/2, 1/4, 1/6 of the width: first order falls 2x, then 1.5x (measured 2.3x and 1.9x)
    assert errors[1] / errors[2] >= 1.7 and errors[2] / errors[3] >= 1.3
    assert errors[-1] < 0.035


def test_the_sag_scales_with_rho_g_over_e_and_the_square_of_the_height():
    _, _, u = column_solution((2, 2, 8))
    mesh = column_mesh((2, 2, 8))
    scaled = structured_box([2 * W, 2 * W, 2 * H], (2, 2, 8), origin=(-W, -W, 0.0))
    fem = LinearFEM(scaled, youngs_modulus=3 * E, poisson_ratio=0.0, fixed=np.flatnonzero(scaled.points[:, 2] < 1e-12))
    v = fem.solve(body_force(scaled, 2 * RHO, G))
    # twice the size (same mesh, scaled), twice ρ, three times E: u scales as ρ g H²/E = 2 · 4 / 3
    assert np.allclose(v, u * 8.0 / 3.0, rtol=1e-9, atol=1e-12 * np.abs(u).max())
    assert mesh.node_count == scaled.node_count


@pytest.mark.parametrize("poisson_ratio", [0.0, 0.3])
def test_the_body_force_and_its_solution_equal_scikit_fems(poisson_ratio):
    mesh, fem, u = column_solution((2, 2, 6), poisson_ratio)
    basis = skfem.Basis(skfem.MeshTet(mesh.points.T, mesh.tets.T), skfem.ElementVector(skfem.ElementTetP1()))

    @skfem.LinearForm
    def weight(v, w):
        return RHO * (G[0] * v[0] + G[1] * v[1] + G[2] * v[2])

    f = skfem.asm(weight, basis)
    k = skfem.asm(linear_elasticity(*lame_parameters(E, poisson_ratio)), basis)
    base = np.flatnonzero(mesh.points[:, 2] < 1e-12)
    theirs = skfem.solve(*skfem.condense(k, f, D=basis.nodal_dofs[:, base].ravel()))
    order = basis.nodal_dofs.T.ravel()      # our dof 3 i + c is skfem's dof order[3 i + c]
    load = body_force(mesh, RHO, G)
    assert np.allclose(load.ravel(), f[order], rtol=1e-12, atol=1e-15 * np.abs(load).max())
    assert np.allclose(u.ravel(), theirs[order], rtol=1e-8, atol=1e-10 * np.abs(u).max())


def column_surface(divisions) -> SurfaceMesh:
    mesh = column_mesh(divisions)
    triangles = mesh.boundary_triangles
    used = np.unique(triangles)
    index = np.full(mesh.node_count, -1)
    index[used] = np.arange(used.size)
    return SurfaceMesh(mesh.points[used], index[triangles].astype(np.int32))


def test_the_volume_methods_give_the_column_its_analytic_sag():
    """Through the solver API (TetGen's meshes of the column's surface, 4 × 4 × 20 faces): fem, hybrid and embedded
    within 1 % of ρgH²/(2E) at the top."""
    hybrid = HybridMesh.build(column_surface((4, 4, 20)))
    v = hybrid.surface.vertices
    base, top = np.flatnonzero(v[:, 2] < 1e-12), v[:, 2] > H - 1e-12
    exact = RHO * GRAVITY * H * H / (2 * E)
    for method in method_names(where=lambda cls: cls.gravity_caveat is None):      # a volume carries the weight
        solver = make_solver(method, hybrid, poisson_ratio=0.0, fixed=base, gravity=G)
        u = solver.solve_static() - v
        assert abs(-u[top, 2].mean() / exact - 1.0) < 0.01, method


# Under gravity alone, over every M_S vertex: the relative RMS difference from the fine FEM and the mean vertical sag
# over the fine FEM's, as measured. The hybrid and embedded methods: the coarse M_V is stiffer than the fine volume
# under a load spread over the whole body. pbd and mass-spring have no volume to carry the weight
# (docs/gravity-and-supports.md): far off, but at known values.
MEASURED = {
    "cube": {"hybrid": (0.0937, 1.091), "embedded": (0.0987, 1.098), "pbd": (0.220, 0.817),
             "mass-spring": (0.860, 0.167)},
    "sphere": {"hybrid": (0.177, 0.915), "embedded": (0.176, 0.918), "pbd": (0.488, 1.088),
               "mass-spring": (0.982, 0.0187)},
    "liver": {"hybrid": (0.231, 0.982), "embedded": (0.229, 0.987), "pbd": (0.471, 0.987),
              "mass-spring": (0.847, 0.375)},
}


@pytest.mark.parametrize("model", ["cube", pytest.param("sphere", marks=pytest.mark.slow),
                                   pytest.param("liver", marks=pytest.mark.slow)])
def test_the_models_sag_as_the_fine_fem_does(model):
    hybrid = HybridMesh.build(models.model(model))
    v = hybrid.surface.vertices
    reference = make_solver("fem", hybrid, gravity=G).solve_static() - v
    scale = np.sqrt(np.mean(np.sum(reference**2, axis=1)))
    for method, (difference, sag) in MEASURED[model].items():
        u = make_solver(method, hybrid, gravity=G).solve_static() - v
        # 10 % over the measured difference and 5 % about the measured sag: a weight counted twice, half or on the
        # wrong nodes leaves both bands (the hybrid's cube at twice its sag differs by 1.0, not 0.094)
        assert np.sqrt(np.mean(np.sum((u - reference) ** 2, axis=1))) / scale <= 1.1 * difference, method
        assert np.mean(u[:, 2]) / np.mean(reference[:, 2]) == pytest.approx(sag, rel=0.05), method
