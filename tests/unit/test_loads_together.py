"""Several tools at once: two pin-heads on one solver hold their loads together, each moved or released alone, and
the static answer under both is the sum of the answers under each (where the method is linear), for every method."""

import numpy as np
import pytest

from tissuesim import HybridMesh, PinHead, make_solver
from tissuesim.mesh import models
from tissuesim.solvers import method_names

#: Methods whose static answer is linear in the load (a linear solve; pbd's static solve is the linearised layer), and
#: the mass-spring model, whose springs act along the current edge directions, so that superposition holds to second
#: order in the displacement only.
LINEAR = method_names(where=lambda cls: cls.linear_in_load)
NONLINEAR = method_names(where=lambda cls: not cls.linear_in_load)
PULL = 0.002  # m of cursor travel: with k = 5 N/m, 10 mN, displacements far below the model's size


@pytest.fixture(scope="module")
def hybrid():
    return HybridMesh.build(models.sphere(resolution=300))


def two_pins(solver):
    """Two pin-heads grabbed on either side of the top, each pulled outward, as a surgeon's two hands."""
    x = solver.rest_positions
    spots = [x[np.argmax(x @ [1.0, 0.0, 1.0])], x[np.argmax(x @ [-1.0, 0.0, 1.0])]]
    pins = []
    for spot, pull in zip(spots, ([PULL, 0.0, 0.0], [-PULL, 0.0, PULL])):
        pin = PinHead(solver, stiffness=5.0)
        pin.grab(spot)
        pin.drag(spot + np.array(pull))
        pins.append(pin)
    return pins


def displacement(solver):
    return solver.solve_static() - solver.rest_positions


@pytest.mark.parametrize("method", LINEAR + NONLINEAR)
def test_two_pin_heads_superpose(hybrid, method):
    solver = make_solver(method, hybrid)
    first, second = two_pins(solver)
    assert len(solver.loads) == 2
    both = displacement(solver)
    node = second.node
    second.release()
    assert [load.node for load in solver.loads] == [first.node]    # releasing one leaves the other alone
    alone_first = displacement(solver)
    first.release()
    second.grab(solver.rest_positions[node])
    second.drag(solver.rest_positions[node] + [-PULL, 0.0, PULL])
    alone_second = displacement(solver)
    scale = np.abs(both).max()
    assert scale > 0.0
    error = np.abs(both - alone_first - alone_second).max() / scale
    # linear methods: round-off of a direct solve; springs: second order in |u| / size (measured 8e-5)
    assert error < (1e-9 if method in LINEAR else 1e-3), error


def test_moving_one_pin_head_leaves_the_other_load_as_it_was(hybrid):
    solver = make_solver("hybrid", hybrid)
    first, second = two_pins(solver)
    held = solver.loads[0].force.copy()
    second.drag(solver.rest_positions[second.node] + [0.0, 0.0, 3 * PULL])
    np.testing.assert_array_equal(solver.loads[0].force, held)     # assigned, untouched
    np.testing.assert_allclose(solver.loads[1].force, [0.0, 0.0, 5.0 * 3 * PULL], rtol=1e-12, atol=1e-15)


def test_solve_static_under_the_loads_acting_keeps_them_and_ignores_dt(hybrid):
    solver = make_solver("hybrid", hybrid)
    two_pins(solver)
    loads = [(load.node, load.force.copy()) for load in solver.loads]
    x = solver.solve_static(dt=0.01)
    y = solver.solve_static(dt=0.001)
    assert [(load.node, load.force.tolist()) for load in solver.loads] == [(n, f.tolist()) for n, f in loads]
    np.testing.assert_allclose(x, y, rtol=0, atol=1e-12 * solver.size)


def test_solve_static_takes_a_node_and_a_force_together_or_neither(hybrid):
    from tissuesim import SolverError

    solver = make_solver("hybrid", hybrid)
    with pytest.raises(SolverError, match="node and a force together"):
        solver.solve_static(3)
