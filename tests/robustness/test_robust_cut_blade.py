"""Sweep items F8 and F28 (the blade): a blade deeper than the body cuts the face it enters first, and a blade
direction of any finite length gives a unit blade (or a refusal naming the direction)."""

import numpy as np
import pytest

from tissuesim import HybridMesh, Scalpel, SolverError, make_solver
from tissuesim.mesh import models


@pytest.fixture(scope="module")
def cube():
    return HybridMesh.build(models.cube(), fine_volume=False)


def test_a_blade_deeper_than_the_body_cuts_the_face_it_enters_first(cube):
    """The sweep's F8: from beside the cube's top rim, a 95 mm blade (the cube is 80 mm high) points down and moves
    across. Its tip meets the top first; the walk that follows the cut must stay on the top, not jump to the
    bottom because both fronts are level along the move."""
    solver = make_solver("pbd", cube)
    n = solver.node_count
    scalpel = Scalpel(solver, depth=0.095)
    scalpel.press([-0.06, 0.0011, 0.09], direction=[0, 0, -1])
    for x in np.linspace(-0.06, 0.06, 31)[1:]:
        scalpel.move([x, 0.0011, 0.09])
    z = solver.rest_positions[n:, 2]
    top = np.count_nonzero(np.isclose(z, 0.08, rtol=0, atol=1e-9))       # new vertices on the faces (rest z)
    bottom = np.count_nonzero(np.isclose(z, 0.0, rtol=0, atol=1e-9))
    # across the top the cut makes a point about every half edge (80 mm, 5.3 mm edges: ~30 points and their
    # copies); the bottom is touched only where the blade enters and leaves down the side faces (~ one edge each)
    assert top >= 40
    assert bottom <= top / 4


@pytest.mark.parametrize("direction, unit", [([1e300, 0, 0], [1, 0, 0]), ([0, -1e-320, 0], [0, -1, 0]),
                                             ([1e308, 1e308, 0], [2 ** -0.5, 2 ** -0.5, 0]),
                                             ([0, 3, -4], [0, 0.6, -0.8])])
def test_a_blade_direction_of_any_finite_length_gives_a_unit_blade(cube, direction, unit):
    scalpel = Scalpel(make_solver("pbd", cube))
    scalpel.press([0.0011, 0.0013, 0.081], direction=direction)
    # unit vectors from a few divisions: round-off only
    assert np.allclose(scalpel.direction, unit, rtol=0, atol=1e-15)
    assert np.linalg.norm(scalpel.direction) == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize("direction", [[0, 0, 0], [np.inf, 0, 0], [np.nan, 0, 1], [1, 0], "down"])
def test_a_blade_direction_that_is_no_direction_is_refused_before_the_press(cube, direction):
    solver = make_solver("pbd", cube)
    scalpel = Scalpel(solver)
    with pytest.raises(SolverError, match=r"blade direction must be .*(finite|non-zero).*inward normal"):
        scalpel.press([0.0011, 0.0013, 0.081], direction=direction)
    assert not scalpel.pressed
