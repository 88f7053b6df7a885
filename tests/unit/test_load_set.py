"""Several loads at once, each by its handle: they add up (exactly where the model is linear), each moves or goes
alone, a refused change changes nothing, and a cut carries every load over."""

import numpy as np
import pytest

import tissuesim
from tissuesim.errors import BoundaryConditionError, SolverError
from tissuesim.experiments.wound import incision_line
from tissuesim.mesh import models
from tissuesim.solvers import method_names

RADIUS = 0.004


@pytest.fixture(scope="module")
def cube():
    return tissuesim.HybridMesh.build(models.cube(400), fine_volume=True)      # the fem's volume too


def _top_nodes(solver, count=2):
    """Free top nodes 2 cm apart on the cube's top face."""
    x = solver.rest_positions
    top = x[:, 2].max()
    picks = []
    for target in ([-0.01, 0.0], [0.01, 0.0], [0.0, 0.015])[:count]:
        on_top = np.flatnonzero(np.isclose(x[:, 2], top))
        picks.append(int(on_top[np.argmin(np.linalg.norm(x[on_top, :2] - target, axis=1))]))
    return picks


@pytest.mark.parametrize("method", method_names(where=lambda cls: cls.linear_in_load))
def test_two_loads_superpose_where_the_model_is_linear(cube, method):
    solver = tissuesim.make_solver(method, cube)
    a, b = _top_nodes(solver)
    fa, fb = np.array([0.0, 0.0, 0.3]), np.array([0.1, 0.0, -0.2])
    alone = []
    for node, force in ((a, fa), (b, fb)):
        solver.reset()
        alone.append(solver.solve_static(node, force, radius=RADIUS) - solver.rest_positions)
    solver.reset()
    first = solver.add_load(a, fa, radius=RADIUS)
    second = solver.add_load(b, fb, radius=RADIUS)
    assert solver.loads == (first, second)
    for _ in range(400):        # the static solve takes one load; stepping holds any number
        solver.step()
    together = solver.positions - solver.rest_positions
    scale = np.abs(alone[0] + alone[1]).max()
    assert np.abs(together - (alone[0] + alone[1])).max() <= 1e-6 * scale     # rested: linear superposition


def test_each_load_moves_and_goes_alone_and_the_forces_are_their_sum(cube):
    solver = tissuesim.make_solver("hybrid", cube)
    a, b, c = _top_nodes(solver, 3)
    first = solver.add_load(a, (0.0, 0.0, 0.3), radius=RADIUS)
    second = solver.add_load(b, (0.0, 0.2, 0.0))
    expected = np.zeros_like(solver.forces)
    np.add.at(expected, first.nodes, first.shares[:, None] * first.force)
    expected[b] += second.force
    np.testing.assert_allclose(solver.forces, expected, rtol=0, atol=1e-15)
    solver.move_load(second, node=c, force=(0.0, 0.0, 0.1))
    assert second.node == c and solver.forces[b].tolist() == [0.0, 0.0, 0.0]    # assigned: exactly zero
    solver.remove_load(first)
    assert solver.loads == (second,)
    node, force = solver.load
    assert node == c and force.tolist() == [0.0, 0.0, 0.1]
    assert np.count_nonzero(np.any(solver.forces, axis=1)) == 1
    with pytest.raises(SolverError, match="does not act on this solver"):
        solver.remove_load(first)
    solver.clear_load()
    assert solver.loads == () and not solver.forces.any()


def test_a_refused_change_changes_nothing_and_one_load_reads_as_before(cube):
    solver = tissuesim.make_solver("hybrid", cube)
    a, b = _top_nodes(solver)
    first = solver.add_load(a, (0.0, 0.0, 0.3), radius=RADIUS)
    forces = solver.forces.copy()
    fixed = int(solver.fixed[0])
    with pytest.raises(BoundaryConditionError):
        solver.add_load(fixed, (0.0, 0.0, 1.0))
    with pytest.raises(BoundaryConditionError):
        solver.move_load(first, node=fixed)
    with pytest.raises(SolverError, match="force"):
        solver.move_load(first, force=(np.nan, 0.0, 0.0))
    np.testing.assert_array_equal(solver.forces, forces)
    assert first.node == a and solver.load[0] == a and solver.load_radius == RADIUS
    solver.add_load(b, (0.0, 0.0, 0.1))
    with pytest.raises(SolverError, match="2 loads act"):
        solver.load


def test_the_near_field_follows_one_contact():
    hybrid = tissuesim.HybridMesh.build(models.cube(400))
    solver = tissuesim.make_solver("hybrid", hybrid, near_field=0.015)
    a, b = _top_nodes(solver)
    solver.add_load(a, (0.0, 0.0, 0.2))
    with pytest.raises(SolverError, match="near field follows one contact"):
        solver.add_load(b, (0.0, 0.0, 0.2))


def test_two_pin_heads_pull_together_and_a_cut_carries_both_loads(cube):
    solver = tissuesim.make_solver("hybrid", cube)
    a, b = _top_nodes(solver)
    pins = [tissuesim.PinHead(solver, stiffness=50.0, radius=RADIUS) for _ in range(2)]
    for pin, node in zip(pins, (a, b)):
        grab_at = solver.positions[node].copy()
        pin.grab(grab_at)
        pin.drag(grab_at + [0.0, 0.0, 0.004])
    assert len(solver.loads) == 2
    start, end = incision_line(solver.rest_positions, length=0.03)
    scalpel = tissuesim.Scalpel(solver, depth=0.01)
    scalpel.press(start + [0.0, 0.02, 0.0], direction=[0.0, 0.0, -1.0])
    scalpel.move(end + [0.0, 0.02, 0.0])
    assert len(solver.loads) == 2 and all(load.nodes.max() < solver.node_count for load in solver.loads)
    for _ in range(5):
        solver.step()
        pins[1].drag(solver.positions[pins[1].node] + [0.0, 0.0, 0.004])
    pins[0].release()
    assert len(solver.loads) == 1 and solver.loads[0].node == pins[1].node


def test_a_haptic_tool_and_a_pin_head_act_together(cube):
    from tissuesim.haptics import HapticLoop

    solver = tissuesim.make_solver("hybrid", cube)
    a, b = _top_nodes(solver)
    pin = tissuesim.PinHead(solver, stiffness=50.0, radius=RADIUS)
    pin.grab(solver.positions[a].copy())
    pin.drag(solver.positions[a] + [0.0, 0.0, 0.004])
    tool = solver.positions[b] + [0.0, 0.0, 0.001]
    loop = HapticLoop(solver, position=lambda: tool, apply_force=lambda force: None, stiffness=200.0, radius=RADIUS)
    loop.grab(b)
    tool = tool + [0.0, 0.0, 0.003]
    loop.tick()
    force = loop.sync()
    assert force[2] > 0.0 and len(solver.loads) == 2          # the pin's load stayed
    assert {load.node for load in solver.loads} == {a, b}
    loop.release()
    assert [load.node for load in solver.loads] == [a]


def test_a_load_keeps_its_own_force_and_its_patch_cannot_be_written(cube):
    solver = tissuesim.make_solver("hybrid", cube)
    a, _ = _top_nodes(solver)
    force = np.array([0.0, 0.0, 0.3])
    load = solver.add_load(a, force, radius=RADIUS)
    force[2] = 5.0                          # the caller reuses its array
    assert load.force.tolist() == [0.0, 0.0, 0.3]
    np.testing.assert_allclose(solver.forces.sum(axis=0), [0.0, 0.0, 0.3], rtol=1e-12)
    with pytest.raises(ValueError):
        load.shares *= 0.5                  # the patch is the solver's cache: read-only
