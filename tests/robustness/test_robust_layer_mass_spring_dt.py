"""A mass-spring time step near the float's top is refused as too many substeps, not an OverflowError.

``step(1e308)`` made ``dt / stable substep`` infinite, and ``math.ceil`` of it raised OverflowError; ``solver.dt =
1e308`` was accepted, so a later ``step()`` did the same. Both are now a SolverError naming dt and the bound, and
change nothing.
"""

import numpy as np
import pytest

from tissuesim import HybridMesh, SolverError, make_solver
from tissuesim.mesh import models
from tissuesim.solvers.mass_spring import MAX_SUBSTEPS, SAFETY

BOUND = rf"dt = .* at most {MAX_SUBSTEPS} allowed, so dt at most .* s\); lower dt"


@pytest.fixture(scope="module")
def cube():
    return HybridMesh.build(models.cube(), fine_volume=False)


@pytest.mark.parametrize("dt", [1e308, 1.7976931348623157e308, 1e200])
def test_a_huge_step_is_refused_and_changes_nothing(cube, dt):
    solver = make_solver("mass-spring", cube)
    with pytest.raises(SolverError, match=BOUND):
        solver.step(dt)
    # exact: a refused step writes nothing, so the state is still the rest positions it was assigned
    np.testing.assert_array_equal(solver.positions, cube.surface.vertices)
    np.testing.assert_array_equal(solver.velocities, 0.0)


def test_a_huge_default_step_is_refused_when_set(cube):
    solver = make_solver("mass-spring", cube)
    before = solver.dt
    with pytest.raises(SolverError, match=BOUND):
        solver.dt = 1e308
    assert solver.dt == before                  # the refused value was never assigned
    solver.step()                               # and the solver still steps at it
    assert np.isfinite(solver.positions).all()


def test_a_step_within_the_bound_is_still_taken(cube):
    solver = make_solver("mass-spring", cube)
    stable = SAFETY * 2.0 / solver.omega_max       # the stable substep [s]
    solver.dt = 0.5 * MAX_SUBSTEPS * stable
    assert solver.substeps(solver.dt) == pytest.approx(0.5 * MAX_SUBSTEPS, abs=1)     # 1: the ceil of a float
