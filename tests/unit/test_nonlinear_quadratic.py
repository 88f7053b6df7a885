"""Finite strain on quadratic tets: the tangent at rest is QuadraticFEM's K, forces and tangent are the derivatives
of the energy, a small load gives the small-strain answer, a rigid motion of the supports costs nothing, and the
constant-factor relaxation reaches Newton's answer."""

import numpy as np
import pytest

from tissuesim.errors import MaterialError
from tissuesim.fem.material import Material
from tissuesim.fem.nonlinear_quadratic import QuadraticNonlinearFEM
from tissuesim.fem.quadratic import QuadraticFEM, quadratic_stiffness
from tissuesim.mesh.regions import nodes_below
from tissuesim.mesh.tetmesh import structured_box

E, NU = 5500.0, 0.3
FINITE = ("corotated", "neo-hookean")
SIZE = (0.02, 0.02, 0.04)


def _bottom(points):
    return nodes_below(points, 0.0)


def _block(material, divisions=(2, 2, 4)):
    mesh = structured_box(SIZE, divisions)
    return QuadraticNonlinearFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=_bottom, material=material)


def _top_pull(fem, force):
    """(N, 3) nodal forces [N]: ``force`` (3,) spread as a uniform traction over the top face (midsides only)."""
    top = np.isclose(fem.rest[:, 2], SIZE[2])
    tris = fem.mesh.boundary_triangles
    tris = tris[np.all(top[tris], axis=1)]
    p = fem.rest
    area = 0.5 * np.linalg.norm(np.cross(p[tris[:, 1]] - p[tris[:, 0]], p[tris[:, 2]] - p[tris[:, 0]]), axis=1)
    weights = fem.linear.traction_weights(tris, area / area.sum())
    return weights[:, None] * np.asarray(force, dtype=float)[None, :]


@pytest.mark.parametrize("material", FINITE)
def test_the_tangent_at_rest_is_the_quadratic_small_strain_stiffness(material):
    fem = _block(material)
    k0 = quadratic_stiffness(fem.mesh, Material(E, NU), fem.elements, fem.node_count)
    tangent = fem.tangent(np.zeros_like(fem.rest), project=False)
    # the same degree-2 rule integrates the same constant Hooke tensor: equal up to summation-order round-off
    assert abs(tangent - k0).max() <= 1e-10 * abs(k0).max()


@pytest.mark.parametrize("material", FINITE)
def test_forces_and_tangent_are_the_derivatives_of_the_energy(material):
    fem = _block(material, divisions=(1, 1, 1))
    rng = np.random.default_rng(7)
    u = 0.004 * rng.standard_normal(fem.rest.shape)     # 10–40 % strains in a 2 cm element: far from linear
    forces = fem.internal_forces(u).copy()
    tangent = fem.tangent(u, project=False).toarray()
    h = 1e-7                                            # central differences: error O(h²) ≪ the tolerances below
    for dof in rng.choice(u.size, 12, replace=False):
        step = np.zeros(u.size)
        step[dof] = h
        plus, minus = u + step.reshape(u.shape), u - step.reshape(u.shape)
        assert (fem.energy(plus) - fem.energy(minus)) / (2 * h) == pytest.approx(forces.ravel()[dof],
                                                                                abs=1e-6 * abs(forces).max())
        difference = (fem.internal_forces(plus).ravel().copy() - fem.internal_forces(minus).ravel()) / (2 * h)
        np.testing.assert_allclose(tangent[:, dof], difference, atol=1e-6 * abs(tangent).max())


@pytest.mark.parametrize("material", FINITE)
def test_a_small_load_gives_the_linear_answer_and_the_difference_grows_quadratically(material):
    fem = _block(material)
    linear = QuadraticFEM(fem.mesh, youngs_modulus=E, poisson_ratio=NU, fixed=_bottom)
    differences = []
    for force in (0.0005, 0.001):                       # N: strains and turns of the bent block about 1e-3
        forces = _top_pull(fem, [0.5 * force, 0.0, force])
        small = linear.solve(forces)
        differences.append(np.linalg.norm(fem.solve(forces) - small) / np.linalg.norm(small))
    assert differences[0] < 0.01
    # The relative difference is linear in the load (the absolute one quadratic): doubling the load doubles it, up
    # to the next order's share, itself O(load) ≈ 1e-3 here; a 10 % band holds it.
    assert differences[1] / differences[0] == pytest.approx(2.0, rel=0.1)


@pytest.mark.parametrize("material", FINITE)
def test_turning_the_supports_turns_the_body_rigidly_without_energy(material):
    fem = _block(material)
    angle = np.radians(60.0)
    c, s = np.cos(angle), np.sin(angle)
    turn = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    moved = fem.rest @ turn.T + [0.01, 0.0, 0.005] - fem.rest
    fem.set_fixed_displacement(moved)
    u = fem.solve(np.zeros_like(fem.rest))
    # midside nodes included: a rigid motion is in the quadratic space, so it is the exact equilibrium
    np.testing.assert_allclose(u, moved, atol=1e-9 * SIZE[2])
    assert fem.energy(u) <= 1e-12 * E * np.prod(SIZE)


@pytest.mark.parametrize("material", FINITE)
def test_a_rigidly_rotated_body_under_a_rotated_load_gives_the_rotated_answer(material):
    fem = _block(material)
    forces = _top_pull(fem, [0.02, 0.0, 0.2])           # N: a 9 % stretch that also bends the block
    u = fem.solve(forces)
    q = np.linalg.qr(np.random.default_rng(5).standard_normal((3, 3)))[0]
    q *= np.sign(np.linalg.det(q))
    turned_mesh = type(fem.mesh)(points=fem.mesh.points @ q.T, tets=fem.mesh.tets)
    fixed = np.isin(np.arange(fem.node_count), fem.free_dofs // 3, invert=True)   # the same nodes, turned
    turned = QuadraticNonlinearFEM(turned_mesh, youngs_modulus=E, poisson_ratio=NU, fixed=lambda p: fixed,
                                   material=material)
    # both solves converge to rtol 1e-9 of the load; the rotation only reorders round-off
    np.testing.assert_allclose(turned.solve(forces @ q.T), u @ q.T, atol=1e-7 * np.abs(u).max())


def test_the_constant_factor_relaxation_reaches_newtons_answer():
    fem = _block("neo-hookean")
    forces = _top_pull(fem, [0.01, 0.0, 0.2])           # N: a 9 % stretch that also bends the block by 3 mm
    static = fem.solve(forces)
    u = np.zeros_like(static)
    fem.relax(forces, u, iterations=30)                 # K₀ of QuadraticFEM: linear convergence, ~10× per 5 steps
    # relax's line search accepts steps within Π's round-off, so it stalls about 1e-6 short of Newton's rtol
    np.testing.assert_allclose(u, static, atol=1e-4 * np.abs(static).max())


def test_an_unknown_material_is_refused():
    with pytest.raises(MaterialError, match="unknown material 'mooney'"):
        _block("mooney")
