"""A moved base (finite strain) where it meets a cut, a half turn, and motions that are no support's motion."""

import numpy as np
import pytest

from tissuesim import HybridMesh, Scalpel, make_solver
from tissuesim.errors import BoundaryConditionError
from tissuesim.mesh import models
from tissuesim.solvers import method_names

#: the methods the scalpel cuts that take the finite-strain (corotated) material of a moved base
CUTTING_FINITE = method_names(cuts=True, material="corotated")


@pytest.fixture(scope="module")
def cube():
    """The built-in cube at its default resolution: a cut 4 mm above its bottom reaches its fixed vertices."""
    return HybridMesh.build(models.cube())


def _turned(rest, degrees, axis):
    """``rest`` turned by ``degrees`` about ``axis`` (0, 1, 2) through its centre."""
    angle = np.radians(degrees)
    c, s = np.cos(angle), np.sin(angle)
    a, b = [i for i in range(3) if i != axis]
    turn = np.eye(3)
    turn[a, a], turn[a, b], turn[b, a], turn[b, b] = c, -s, s, c
    centre = rest.mean(axis=0)
    return (rest - centre) @ turn.T + centre


@pytest.mark.parametrize("method", CUTTING_FINITE)
def test_reset_after_a_cut_that_reaches_a_moved_base_returns_to_rest(cube, method):
    solver = make_solver(method, cube, material="corotated")
    base = solver.rest_positions[solver.fixed]
    solver.set_fixed_positions(base + [0.002, 0.0, 0.0])
    solver.step()
    scalpel = Scalpel(solver, depth=0.012)
    scalpel.press([-0.0405, 0.0, 0.004], direction=[1.0, 0.0, 0.0])
    for y in np.linspace(0.0, 0.03, 9)[1:]:
        scalpel.move([-0.0405, y, 0.004])
    scalpel.release()
    assert solver.fixed.size > base.shape[0]           # the cut made fixed vertices of its own
    solver.reset()
    solver.step()
    np.testing.assert_array_equal(solver.fixed_positions, solver.rest_positions[solver.fixed])
    assert np.abs(solver.positions - solver.rest_positions).max() < 1e-9 * solver.size
    moved = solver.rest_positions[solver.fixed] + [0.0, 0.003, 0.0]      # and the base moves again
    solver.set_fixed_positions(moved)
    solver.step()
    np.testing.assert_allclose(solver.positions[solver.fixed], moved, atol=1e-12)
    assert np.abs(solver.positions - solver.rest_positions - [0.0, 0.003, 0.0]).max() < 1e-6 * solver.size


@pytest.mark.parametrize("method,material", [("hybrid", "corotated"), ("embedded", "corotated"),
                                             ("embedded", "neo-hookean"), ("fem", "corotated")])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_a_half_turn_of_the_base_moves_the_unloaded_body_to_the_rigid_pose(small_cube, small_cube_top, method,
                                                                           material, axis):
    """A half turn is a rigid motion like any other: a static solve (from rest, the default) and steps both reach
    the turned body exactly."""
    rest = small_cube.surface.vertices
    expected = _turned(rest, 180.0, axis)
    solver = make_solver(method, small_cube, material=material)
    solver.set_fixed_positions(expected[solver.fixed])
    for _ in range(3):
        solver.step()
    assert np.abs(solver.positions - expected).max() < 1e-9 * solver.size
    solver.solve_static(small_cube_top, [0.0, 0.0, 0.0])
    assert np.abs(solver.positions - expected).max() < 1e-9 * solver.size


def test_a_half_turned_base_carries_the_hybrids_surface_layer_without_its_warm_start(small_cube):
    expected = _turned(small_cube.surface.vertices, 180.0, 0)
    solver = make_solver("hybrid", small_cube, material="corotated", warm_start=False)
    solver.set_fixed_positions(expected[solver.fixed])
    for _ in range(3):
        solver.step()
    assert np.abs(solver.positions - expected).max() < 1e-9 * solver.size


def test_a_half_turn_of_the_base_on_the_default_cube_steps_the_embedded_body_to_the_rigid_pose(cube):
    rest = cube.surface.vertices
    expected = _turned(rest, 180.0, 0)
    solver = make_solver("embedded", cube, material="corotated")
    solver.set_fixed_positions(expected[solver.fixed])
    solver.step()
    assert np.abs(solver.positions - expected).max() < 1e-9 * solver.size


@pytest.mark.parametrize("point", [[0.0, 0.0, 0.0], [0.01, 0.02, 0.03], [-0.05, 0.1, 0.2]])
def test_gathering_the_base_to_one_point_is_called_a_crush(small_cube, point):
    from tissuesim.mesh import models as meshes

    for hybrid in (small_cube, HybridMesh.build(meshes.liver(resolution=600))):
        solver = make_solver("embedded", hybrid, material="corotated")
        base = solver.rest_positions[solver.fixed].copy()
        with pytest.raises(BoundaryConditionError, match="crushes") as refused:
            solver.set_fixed_positions(np.broadcast_to(point, base.shape))
        assert "mirror" not in str(refused.value)
        np.testing.assert_array_equal(solver.fixed_positions, base)


@pytest.mark.parametrize("shift", [1e300, 1000.0, 2.0])
def test_a_base_carried_absurdly_far_is_refused_where_it_is_given(small_cube, small_cube_size, shift):
    """1 km (or 1e300 m) on a 14 cm body was taken, and the next step failed as a divergence "under no load"."""
    solver = make_solver("hybrid", small_cube, material="corotated")
    base = solver.rest_positions[solver.fixed].copy()
    with pytest.raises(BoundaryConditionError, match=r"times the body's size .*within 10 sizes of rest"):
        solver.set_fixed_positions(base + shift)
    np.testing.assert_array_equal(solver.fixed_positions, base)
    solver.step()
    assert np.abs(solver.positions - solver.rest_positions).max() < 1e-12
    solver.set_fixed_positions(base + [5.0 * small_cube_size, 0.0, 0.0])      # far, but a carry
    solver.step()
    assert np.abs(solver.positions - solver.rest_positions - [5.0 * small_cube_size, 0.0, 0.0]).max() < 1e-6


def test_fixed_vertices_scattered_independently_are_no_support_motion(small_cube):
    solver = make_solver("embedded", small_cube, material="corotated")
    base = solver.rest_positions[solver.fixed].copy()
    scattered = base + np.random.default_rng(3).normal(scale=0.01, size=base.shape)
    with pytest.raises(BoundaryConditionError, match=r"no support's motion: vertex \d+ of it lies .* affine map"):
        solver.set_fixed_positions(scattered)
    np.testing.assert_array_equal(solver.fixed_positions, base)
    centre = base.mean(axis=0)
    squeezed = (base - centre) * [0.7, 1.0, 1.0] + centre       # a jaw's squeeze is affine: taken
    solver.set_fixed_positions(squeezed)
    np.testing.assert_array_equal(solver.fixed_positions, squeezed)
