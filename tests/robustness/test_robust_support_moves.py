"""A moved base (finite strain) where it meets a cut, a half turn, and motions that are no support's motion."""

import numpy as np
import pytest

from tissuesim import HybridMesh, Scalpel, make_solver
from tissuesim.errors import BoundaryConditionError
from tissuesim.mesh import models


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


@pytest.mark.parametrize("method", ["hybrid", "embedded"])
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


def test_a_half_turn_of_the_base_on_the_default_cube_steps_the_embedded_body_to_the_rigid_pose(cube):
    rest = cube.surface.vertices
    expected = _turned(rest, 180.0, 0)
    solver = make_solver("embedded", cube, material="corotated")
    solver.set_fixed_positions(expected[solver.fixed])
    solver.step()
    assert np.abs(solver.positions - expected).max() < 1e-9 * solver.size
