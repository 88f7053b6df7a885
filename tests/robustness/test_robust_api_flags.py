"""The solvers' switches are True or False: text is refused (``warm_start="no"`` was taken as on, as any non-empty
string is true), as scene files refuse it."""

import numpy as np
import pytest

from tissuesim import SolverError, make_solver


@pytest.mark.parametrize("value", ["no", "False", 0, [False]])
def test_a_switch_that_is_not_a_bool_is_refused(small_cube, small_cube_top, value):
    with pytest.raises(SolverError, match=r"warm_start is True or False, got .*; pass warm_start=False"):
        make_solver("hybrid", small_cube, warm_start=value)
    with pytest.raises(SolverError, match=r"signed_bending is True or False"):
        make_solver("pbd", small_cube, signed_bending=value)
    solver = make_solver("pbd", small_cube)
    solver.add_load(small_cube_top, [0.0, 0.0, 0.1])
    with pytest.raises(SolverError, match=r"reset is True or False"):
        solver.solve_static(small_cube_top, [0.0, 0.0, 1.0], reset=value)
    assert [tuple(load.force) for load in solver.loads] == [(0.0, 0.0, 0.1)]     # refused before anything changed


def test_none_is_no_warm_start_switch(small_cube):
    with pytest.raises(SolverError, match=r"warm_start is True or False, got None"):
        make_solver("hybrid", small_cube, warm_start=None)      # signed_bending=None is its default: taken


@pytest.mark.parametrize("value", [False, np.False_])
def test_bools_are_taken(small_cube, value):
    assert make_solver("hybrid", small_cube, warm_start=value).warm_start is False
    assert make_solver("pbd", small_cube, signed_bending=value).signed_bending is False
