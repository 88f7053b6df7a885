"""The finite-strain near field and its quadratic volume against what nobody here wrote: the exact homogeneous
uniaxial stretch, the small-strain response at a small force, and the same equilibrium however a drag reaches it."""

from functools import partial

import numpy as np
import pytest
from test_finite_strain import FINITE, SIZE, _analytic_uniaxial

import tissuesim
from tissuesim.errors import MaterialError, SolverError
from tissuesim.experiments.protocol import load_node
from tissuesim.fem.nonlinear_quadratic import QuadraticNonlinearFEM
from tissuesim.loads import contact_patch
from tissuesim.mesh import models
from tissuesim.mesh.regions import bottom_height, nodes_below
from tissuesim.mesh.tetmesh import structured_box
from tissuesim.solvers.near_field import NearField

E, NU = 5500.0, 0.3
RADIUS = 0.008  # m: a patch of several nodes on the small cube


@pytest.mark.parametrize("material", FINITE)
@pytest.mark.parametrize("traction", [500.0, 3000.0])   # 0.1 and 0.55 E: from mild to a 40 % stretch
def test_quadratic_uniaxial_tension_is_the_exact_homogeneous_stretch(material, traction):
    mesh = structured_box(SIZE, (2, 2, 4))
    # rollers: each coordinate held on its own zero plane, so the block contracts freely sideways
    fem = QuadraticNonlinearFEM(mesh, youngs_modulus=E, poisson_ratio=NU, fixed=lambda p: np.isclose(p, 0.0),
                                material=material)
    p = fem.rest
    tris = mesh.boundary_triangles
    tris = tris[np.all(np.isclose(p[tris, 2], SIZE[2]), axis=1)]
    area = 0.5 * np.linalg.norm(np.cross(p[tris[:, 1]] - p[tris[:, 0]], p[tris[:, 2]] - p[tris[:, 0]]), axis=1)
    forces = np.zeros_like(p)
    forces[:, 2] = fem.linear.traction_weights(tris, area * traction)
    u = fem.solve(forces)
    a, s = _analytic_uniaxial(material, traction)
    # quadratic tets represent a homogeneous deformation exactly, midsides included: only the solver's rtol remains
    np.testing.assert_allclose(p + u, p * [a, a, s], atol=1e-6 * SIZE[2])


@pytest.fixture(scope="module")
def cube():
    hybrid = tissuesim.HybridMesh.build(models.cube(400), fine_volume=True)
    surface = hybrid.surface
    node = load_node(surface.vertices, surface.triangles)
    patch = contact_patch(surface.vertices, surface.triangles, node, RADIUS)
    window = np.flatnonzero(np.linalg.norm(surface.vertices - surface.vertices[node], axis=1) <= 0.015)
    return hybrid, patch, window


def _near(hybrid, material):
    fixed = partial(nodes_below, height=bottom_height(hybrid.surface.vertices))
    return NearField(hybrid, youngs_modulus=E, poisson_ratio=NU, fixed=fixed, material=material)


def test_the_linear_near_field_is_its_response_times_the_force(cube):
    hybrid, (patch, shares), window = cube
    near = _near(hybrid, "linear")
    force = np.array([0.3, -0.2, 1.0])
    # the same product the hybrid formed before: bit-identical
    np.testing.assert_array_equal(near.displacement(patch, shares, force, window),
                                  near.response(patch, shares, window) @ force)


@pytest.mark.parametrize("material", FINITE)
def test_at_a_small_force_the_finite_near_field_is_the_linear_one(cube, material):
    hybrid, (patch, shares), window = cube
    force = [0.0, 0.0, 0.01]                             # N: 1 % of the 1 N pull, strains about 1e-3
    linear = _near(hybrid, "linear").displacement(patch, shares, force, window)
    finite = _near(hybrid, material).displacement(patch, shares, force, window)
    assert np.linalg.norm(finite - linear) / np.linalg.norm(linear) < 0.01


def test_a_drag_reaches_the_equilibrium_of_a_solve_from_rest_in_fewer_iterations(cube):
    hybrid, (patch, shares), window = cube
    force = np.array([0.5, 0.0, 2.0])                    # N: a 2 N pull leaning sideways, far from linear
    cold = _near(hybrid, "neo-hookean")
    reference = cold.displacement(patch, shares, force, window)
    from_rest = cold.last_iterations
    drag = _near(hybrid, "neo-hookean")
    for fraction in (0.9, 1.0):                          # a drag: the same contact, the force growing
        dragged = drag.displacement(patch, shares, fraction * force, window)
    # both converged to rtol 1e-9 of the load on the same equilibrium (a stable one is unique near here)
    np.testing.assert_allclose(dragged, reference, atol=1e-6 * np.abs(reference).max())
    assert 0 < drag.last_iterations < from_rest
    # the same force again: already in equilibrium, so no iteration and nothing moves
    np.testing.assert_array_equal(drag.displacement(patch, shares, force, window), dragged)
    assert drag.last_iterations == 0


def test_interactive_steps_under_a_constant_force_settle_at_the_converged_answer(cube):
    hybrid, (patch, shares), window = cube
    force = np.array([0.5, 0.0, 2.0])                    # N
    near = _near(hybrid, "neo-hookean")
    converged = near.displacement(patch, shares, force, window)
    steps = _near(hybrid, "neo-hookean")
    for frame in range(20):                              # frames of three constant-factor iterations each
        stepped = steps.displacement(patch, shares, force, window, iterations=3)
        assert frame > 0 or not steps.settled            # three iterations from rest: not yet the equilibrium
    # K₀'s iterations contract the error about 10× per dozen here (60: ~3e-6), and stall near 1e-7 at Π's round-off
    np.testing.assert_allclose(stepped, converged, atol=1e-4 * np.abs(converged).max())
    assert near.settled


def test_after_a_reset_the_near_field_starts_from_rest(cube):
    hybrid, (patch, shares), window = cube
    force = np.array([0.0, 0.0, 1.0])                    # N
    fresh = _near(hybrid, "neo-hookean").displacement(patch, shares, force, window, iterations=1)
    near = _near(hybrid, "neo-hookean")
    near.displacement(patch, shares, 2 * force, window)  # a converged answer to start from, then forgotten
    near.reset()
    # the same arithmetic from rest: equal to round-off, while a warm start would be a whole iteration apart
    np.testing.assert_allclose(near.displacement(patch, shares, force, window, iterations=1), fresh,
                               atol=1e-12 * np.abs(fresh).max())


@pytest.mark.slow    # about a minute: load stepping halves the press down to 1/32 before it gives up
def test_a_press_with_no_stable_equilibrium_is_refused_and_the_drag_goes_on_from_its_last_answer(cube):
    hybrid, (patch, shares), window = cube
    near = _near(hybrid, "neo-hookean")
    before = near.displacement(patch, shares, [0.0, 0.0, 0.5], window)
    with pytest.raises(SolverError, match="no stable equilibrium|unstable"):
        near.displacement(patch, shares, [0.0, 0.0, -20.0], window)   # N: a dead-load press far above μ
    np.testing.assert_array_equal(near.displacement(patch, shares, [0.0, 0.0, 0.5], window), before)
    assert near.last_iterations == 0


def test_bad_material_and_force_are_refused(cube):
    hybrid, (patch, shares), window = cube
    with pytest.raises(MaterialError, match="unknown material 'rubber'"):
        _near(hybrid, "rubber")
    with pytest.raises(SolverError, match=r"finite \(3,\) vector"):
        _near(hybrid, "linear").displacement(patch, shares, [0.0, np.nan, 1.0], window)
