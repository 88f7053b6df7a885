"""A finite-strain solver put back at rest says nothing of the collapse it was in: the fem and embedded volumes keep
their last displacement as the next solve's warm start, and ``Solver.warning`` (which a viewer shows every frame)
judged that warm start instead of the body at rest."""

import numpy as np

from tissuesim import make_solver


def test_reset_clears_the_collapse_warning(small_cube, small_cube_top):
    solver = make_solver("fem", small_cube, material="neo-hookean")
    solver.solve_static(small_cube_top, (3.0, 0.0, 0.0), radius=0.004)
    assert "collapses under this load" in solver.warning
    solver.reset()
    np.testing.assert_array_equal(solver.positions, solver.rest_positions)
    assert solver.warning is None
    solver.solve_static(small_cube_top, (3.0, 0.0, 0.0), radius=0.004)      # the same load: the same warning
    assert "collapses under this load" in solver.warning
