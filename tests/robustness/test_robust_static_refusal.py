"""A finite-strain static solve refused for want of a stable equilibrium changes nothing: the state, the loads and
the volume's own displacement are those before the call, so the next step equals a twin's that never tried it
(the hybrid's volume was left at rest while its surface was put back, and its next step jumped by millimetres).

A real refusal (a 2 kN pull on the cube) takes the load stepping 10-20 s to find; the volume's solve is made to
refuse at once here, after scribbling on the displacement it was given, as a failed Newton may."""

import numpy as np
import pytest

from tissuesim import SolverError, make_solver
from tissuesim.fem.nonlinear import UnstableLoadError
from tissuesim.solvers import method_names

#: the methods that take the finite-strain (corotated) material: their static solve may find no equilibrium
FINITE_STRAIN = method_names(material="corotated")


def _loaded(hybrid, method, side):
    solver = make_solver(method, hybrid, material="corotated")
    solver.add_load(side, [0.3, 0.0, 0.0])
    for _ in range(3):
        solver.step()
    return solver


@pytest.mark.parametrize("reset", [True, False])
@pytest.mark.parametrize("method", FINITE_STRAIN)
def test_a_refused_finite_strain_solve_changes_nothing(small_cube, small_cube_top, method, reset):
    side = int(np.argmin(np.linalg.norm(small_cube.surface.vertices - [0.04, 0.0, 0.04], axis=1)))
    solver, twin = _loaded(small_cube, method, side), _loaded(small_cube, method, side)

    def fails(forces, *, initial, **options):
        initial += 1e-3
        raise UnstableLoadError("no stable equilibrium", reached=0.5)

    solver.finite.solve = fails
    with pytest.raises(SolverError, match="has no stable equilibrium"):
        solver.solve_static(small_cube_top, [0.0, 0.0, 2.0], reset=reset)
    del solver.finite.solve
    for name in ("positions", "velocities", "volume_displacement"):
        np.testing.assert_array_equal(getattr(solver, name), getattr(twin, name), err_msg=name)
    assert [(load.node, tuple(load.force)) for load in solver.loads] == \
        [(load.node, tuple(load.force)) for load in twin.loads]
    solver.step()
    twin.step()
    np.testing.assert_array_equal(solver.positions, twin.positions)
