"""The hybrid's near field: the quadratic traction weights, the window of prescribed nodes, and what a cut does."""

import numpy as np
import pytest

import tissuesim
from tissuesim.experiments.wound import scripted_incision
from tissuesim.errors import SolverError, TissuesimWarning
from tissuesim.experiments.protocol import load_node
from tissuesim.fem.quadratic import QuadraticFEM
from tissuesim.mesh import models
from tissuesim.mesh.regions import nodes_below
from tissuesim.mesh.tetmesh import TetMesh

RADIUS = 0.008  # m
FORCE = np.array([0.0, 0.0, -0.05])  # N


@pytest.fixture(scope="module")
def cube():
    return tissuesim.HybridMesh.build(models.cube(400), fine_volume=True)


@pytest.fixture(scope="module")
def node(cube):
    return load_node(cube.surface.vertices, cube.surface.triangles)


def _tet():
    points = np.array([[0.0, 0.0, 0.0], [0.03, 0.0, 0.0], [0.01, 0.02, 0.0], [0.01, 0.01, 0.02]])
    mesh = TetMesh(points, np.array([[0, 1, 2, 3]], dtype=np.int32))
    return QuadraticFEM(mesh, youngs_modulus=5500.0, poisson_ratio=0.3, fixed=lambda p: nodes_below(p, 0.0))


def test_linear_traction_weights_integrate_quadratic_fields_exactly():
    fem = _tet()
    face = np.array([[0, 1, 2]])
    density = np.array([[2.0, -1.0, 5.0]])     # per m², a linear traction over the face
    weights = fem.linear_traction_weights(face, density)
    # Σ w_a v(x_a) = ∫ t v dA for v = x², which the quadratic nodes interpolate exactly; the integral by a fine
    # midpoint rule on the face's barycentric grid, independent of the formula.
    k = 400
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    keep = i + j < k
    up = np.stack([(i + 1 / 3) / k, (j + 1 / 3) / k], axis=-1)[keep]
    down = np.stack([(i + 2 / 3) / k, (j + 2 / 3) / k], axis=-1)[(i + j < k - 1)]
    bary = np.concatenate([up, down])
    bary = np.column_stack([1 - bary.sum(axis=1), bary])
    p = bary @ fem.points[:3]
    area = 0.5 * np.linalg.norm(np.cross(fem.points[1] - fem.points[0], fem.points[2] - fem.points[0]))
    integral = np.sum((bary @ density[0]) * p[:, 0] ** 2) * area / len(bary)
    assert np.isclose(weights @ fem.points[:, 0] ** 2, integral, rtol=1e-4)
    assert np.isclose(weights.sum(), area * density.mean())


def test_a_uniform_density_is_the_uniform_traction():
    fem = _tet()
    face = np.array([[0, 1, 2]])
    area = 0.5 * np.linalg.norm(np.cross(fem.points[1] - fem.points[0], fem.points[2] - fem.points[0]))
    assert np.allclose(fem.linear_traction_weights(face, np.full((1, 3), 1.0 / area)),
                       fem.traction_weights(face, [1.0]))


def test_bad_traction_input_is_refused():
    fem = _tet()
    with pytest.raises(SolverError, match="corner densities"):
        fem.linear_traction_weights([[0, 1, 2]], [[1.0, np.nan, 1.0]])
    with pytest.raises(SolverError, match="integer triangles"):
        fem.linear_traction_weights([[0.0, 1.0, 2.0]], [[1.0, 1.0, 1.0]])


@pytest.mark.parametrize("value", [0.0, -0.01, np.inf, np.nan, True, "15 mm"])
def test_near_field_must_be_a_positive_distance(cube, value):
    with pytest.raises(SolverError, match="near_field must be"):
        tissuesim.make_solver("hybrid", cube, near_field=value)


def test_near_field_needs_the_fine_volume():
    without = tissuesim.HybridMesh.build(models.cube(400), fine_volume=False)
    with pytest.raises(SolverError, match="fine_volume=True"):
        tissuesim.make_solver("hybrid", without, near_field=0.015)


def test_the_window_follows_the_fine_response_and_the_layer_relaxes_the_rest(cube, node):
    solver = tissuesim.make_solver("hybrid", cube, near_field=0.015)
    rest = solver.rest_positions
    x = solver.solve_static(node, FORCE, radius=RADIUS)
    distance = np.linalg.norm(rest - rest[node], axis=1)
    window = np.flatnonzero((distance <= 0.015) & ~np.isin(np.arange(len(rest)), solver.fixed))
    assert np.array_equal(solver.near_window, window) and window.size >= 9
    fine = solver._near.response(solver.load_nodes, solver.load_shares, window) @ FORCE
    assert np.allclose(x[window], rest[window] + fine, rtol=0, atol=1e-12)
    assert set(window) <= set(solver.prescribed.tolist())
    outside = np.setdiff1d(np.flatnonzero(distance > 0.03), solver.prescribed)
    assert outside.size and np.abs(x[outside] - rest[outside]).max() > 0   # the layer moved them
    solver.clear_load()
    solver.step()
    assert solver.near_window.size == 0 and solver.prescribed.size == solver._held.size


def test_a_window_over_every_node_is_the_fine_response(cube, node):
    solver = tissuesim.make_solver("hybrid", cube, near_field=1.0)
    x = solver.solve_static(node, FORCE, radius=RADIUS)
    free = np.setdiff1d(np.arange(len(x)), solver.fixed)
    fine = solver._near.response(solver.load_nodes, solver.load_shares, free) @ FORCE
    assert np.allclose(x[free] - solver.rest_positions[free], fine, rtol=0, atol=1e-12)
    for _ in range(3):
        solver.step()
    assert np.allclose(solver.positions[free] - solver.rest_positions[free], fine, rtol=0, atol=1e-12)


def test_a_cut_switches_the_near_field_off_and_the_hybrid_goes_on(cube, node):
    solver = tissuesim.make_solver("hybrid", cube, near_field=0.015)
    solver.set_load(node, FORCE, radius=RADIUS)
    solver.step()
    with pytest.warns(TissuesimWarning, match="near field"):
        scripted_incision(solver)
    assert solver.near_field is None
    for _ in range(50):
        solver.step()
    assert np.all(np.isfinite(solver.positions))


def test_a_cut_mesh_takes_no_near_field(cube):
    solver = tissuesim.make_solver("hybrid", cube)
    scripted_incision(solver)
    with pytest.raises(SolverError, match="uncut mesh"):
        tissuesim.make_solver("hybrid", solver.hybrid, near_field=0.015)


@pytest.mark.parametrize("value", ["-5", "0", "nan"])
def test_view_refuses_a_bad_near_field_in_one_line(value, capsys):
    from tissuesim.cli import main

    assert main(["view", "cube", "--near-field", value]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--near-field" in err[0] and "mm" in err[0]
