"""A quasi-static solve that does not settle is refused and changes nothing (the loads, the state and the report
are as before); the experiments' ``keep_unsettled`` keeps the last state of an unsettled solve, reported as not
converged."""

import numpy as np
import pytest

from tissuesim import make_solver
from tissuesim.errors import SolverError


def _state(solver):
    return (solver.positions.copy(), solver.state.velocities.copy(), solver.forces.copy(), solver.last_solve)


def test_an_unsettled_solve_is_refused_and_changes_nothing(small_cube, small_cube_top):
    solver = make_solver("mass-spring", small_cube)       # the method that settles by stepping
    solver.add_load(small_cube_top, [0.0, 0.01, -0.03])
    solver.step()
    before = _state(solver)
    with pytest.raises(SolverError, match="did not settle within 3 steps"):
        solver.solve_static(small_cube_top, [0.0, 0.0, -0.1], max_steps=3)
    after = _state(solver)
    for name, was, now in zip(("positions", "velocities", "forces"), before, after):
        np.testing.assert_array_equal(now, was, err_msg=name)
    assert after[3] is before[3]


def test_keep_unsettled_keeps_the_last_state_and_says_so(small_cube, small_cube_top):
    solver = make_solver("mass-spring", small_cube)
    positions = solver.solve_static(small_cube_top, [0.0, 0.0, -0.1], max_steps=3, keep_unsettled=True)
    assert not solver.last_solve.converged and solver.last_solve.steps == 3
    np.testing.assert_array_equal(positions, solver.positions)
    assert np.abs(solver.displacements).max() > 0.0
