"""A load on a fixed node is refused, and the pin-head passes fixed nodes over for the nearest node a load moves."""

import numpy as np
import pytest

from tissuesim import PinHead, make_solver
from tissuesim.errors import BoundaryConditionError, SolverError
from tissuesim.solvers import available_solvers

METHODS = available_solvers()


def highest_fixed(solver) -> int:
    """The fixed node nearest the free part of the body: the highest one (on a side of the cube)."""
    return int(solver.fixed[np.argmax(solver.rest_positions[solver.fixed, 2])])


def loaded(method, small_cube, small_cube_top):
    """A solver of ``method`` under 0.5 N on the top node, stepped away from rest."""
    solver = make_solver(method, small_cube)
    solver.set_load(small_cube_top, [0.0, 0.0, 0.5])
    for _ in range(3):
        solver.step()
    return solver


def snapshot(solver):
    return (solver.positions.copy(), solver.velocities.copy(), solver.forces.copy(), solver.load)


def assert_unchanged(solver, before):
    positions, velocities, forces, load = before
    # exact: a refused call must not have written anything
    assert np.array_equal(solver.positions, positions) and np.array_equal(solver.velocities, velocities)
    assert np.array_equal(solver.forces, forces)
    assert solver.load[0] == load[0] and np.array_equal(solver.load[1], load[1])


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("radius", [None, 0.004])
def test_a_load_on_a_fixed_node_is_refused_and_changes_nothing(small_cube, small_cube_top, method, radius):
    solver = loaded(method, small_cube, small_cube_top)
    node = highest_fixed(solver)
    before = snapshot(solver)
    with pytest.raises(BoundaryConditionError, match=rf"node {node} is fixed.*load a free node"):
        solver.set_load(node, [0.0, 0.0, 1.0], radius=radius)
    assert_unchanged(solver, before)
    with pytest.raises(BoundaryConditionError, match=rf"node {node} is fixed"):
        solver.solve_static(node, [0.0, 0.0, 1.0], radius=radius)       # reset=True: refused before the reset
    assert_unchanged(solver, before)


@pytest.mark.parametrize("method", METHODS)
def test_a_bad_radius_in_solve_static_leaves_the_state_as_it_was(small_cube, small_cube_top, method):
    solver = loaded(method, small_cube, small_cube_top)
    before = snapshot(solver)
    with pytest.raises(SolverError, match="contact radius"):
        solver.solve_static(small_cube_top, [0.0, 0.0, 1.0], radius=-0.004)
    assert_unchanged(solver, before)


@pytest.mark.parametrize("method", METHODS)
def test_grab_on_a_fixed_node_holds_the_nearest_free_node_and_the_drag_moves_it(small_cube, method):
    solver = make_solver(method, small_cube)
    pin = PinHead(solver, stiffness=20.0)
    fixed = highest_fixed(solver)
    point = solver.positions[fixed].copy()
    node = pin.grab(point)
    assert node != fixed and node not in solver.fixed
    free = np.setdiff1d(np.arange(solver.node_count), solver.fixed)
    nearest_free = free[np.argmin(np.linalg.norm(solver.positions[free] - point, axis=1))]
    assert node == nearest_free
    assert f"node {fixed}" in pin.notice and "is fixed" in pin.notice and f"node {node}" in pin.notice
    force = pin.drag(point + [0.01, 0.0, 0.0])          # 0.2 N outward-ish along x
    for _ in range(10):
        solver.step()
    moved = solver.positions[node] - small_cube.surface.vertices[node]
    assert moved @ force > 0.0                           # the held node follows the pull


@pytest.mark.parametrize("method", METHODS)
def test_grab_with_a_tip_passes_over_nodes_whose_patch_reaches_the_support(small_cube, method):
    solver = make_solver(method, small_cube)
    tip = 0.012      # the cube's edges are 10 mm: the lowest free row's tips reach the fixed row, the next row's do not
    free = np.setdiff1d(np.arange(solver.node_count), solver.fixed)
    low = int(free[np.argmin(solver.rest_positions[free, 2])])
    pin = PinHead(solver, stiffness=20.0, radius=tip)
    assert solver.support_reached(low, tip).size
    node = pin.grab(solver.positions[low])
    assert node != low and not solver.support_reached(node, tip).size
    assert "reaches the fixed region" in pin.notice
    pin.drag(solver.positions[low] + [0.0, 0.0, 0.01])
    assert not np.isin(solver.load_nodes, solver.fixed).any()


def test_grab_in_the_middle_of_the_support_is_refused_and_holds_nothing(small_cube):
    solver = make_solver("hybrid", small_cube)
    pin = PinHead(solver, stiffness=20.0)
    rest = solver.rest_positions
    bottom = solver.fixed[np.argmin(np.linalg.norm(rest[solver.fixed, :2] - rest[:, :2].mean(axis=0), axis=1))]
    with pytest.raises(SolverError, match=r"fixed region.*grab farther from the support"):
        pin.grab(rest[bottom])
    assert not pin.grabbed and solver.load is None


def test_a_grab_that_needs_no_detour_says_nothing(small_cube, small_cube_top):
    pin = PinHead(make_solver("pbd", small_cube), stiffness=20.0)
    pin.grab(small_cube.surface.vertices[highest_fixed(pin.solver)])
    assert pin.notice
    assert pin.grab(small_cube.surface.vertices[small_cube_top]) == small_cube_top and pin.notice == ""
