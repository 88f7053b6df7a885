"""The surface layer's iteration count is a positive integer: anything else (text, a list, None, NaN) is refused with
the solvers' own error naming the option and the fix, never a TypeError or ValueError from int()."""

import pytest

from tissuesim import SolverError, make_solver
from tissuesim.solvers import method_names
from tissuesim.solvers.surface_layer import SurfaceLayerSolver

#: the methods with a surface layer: the layer's projection takes the iterations option
SURFACE_LAYER = method_names(where=lambda cls: issubclass(cls, SurfaceLayerSolver))


@pytest.mark.parametrize("method", SURFACE_LAYER)
@pytest.mark.parametrize("value", [[1, 2], "abc", "20", None, float("nan"), 1 + 1j, {"a": 1}, 2.5, 0, True])
def test_iterations_not_a_positive_integer_is_refused(small_cube, method, value):
    with pytest.raises(SolverError, match=r"iterations must be a positive integer.*e\.g\. 10"):
        make_solver(method, small_cube, iterations=value)


def test_integral_iterations_are_taken(small_cube):
    assert make_solver("pbd", small_cube, iterations=7.0).iterations == 7
