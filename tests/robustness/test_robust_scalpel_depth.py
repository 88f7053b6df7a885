"""The scalpel's blade and tool stay within the model's reach: a blade longer than the model, or a move far off it,
is refused naming the value and the bound, and a refused move changes nothing."""

import re

import numpy as np
import pytest

from tissuesim import Scalpel, SolverError, make_solver

TOP = [0.0, 0.0, 0.08]  # the centre of the 8 cm cube's top


@pytest.fixture()
def solver(small_cube):
    return make_solver("hybrid", small_cube)


@pytest.mark.parametrize("depth", [1e8, 1e155, 1e200])
def test_a_blade_longer_than_the_model_is_refused_naming_the_bound(solver, small_cube_size, depth):
    # before: 1e8 cut the fixed bottom face, 1e155 split triangles at every height, 1e200 cut nothing silently
    with pytest.raises(SolverError, match=re.escape(f"blade depth {depth:.4g} m is longer than the model's size")) as error:
        Scalpel(solver, depth=depth)
    assert f"at most {small_cube_size:.4g} m" in str(error.value)


def test_a_blade_as_long_as_the_model_is_taken(solver, small_cube_size):
    assert Scalpel(solver, depth=small_cube_size).depth == small_cube_size


@pytest.mark.parametrize("point", [[1e300, 0.0, 0.08], [0.0, 0.0, 1.0]])
def test_a_move_far_off_the_model_is_refused_and_changes_nothing(solver, point):
    scalpel = Scalpel(solver, depth=0.01)
    scalpel.press(TOP)
    scalpel.move([0.004, 0.0, 0.08])
    tip, triangles = scalpel.tip.copy(), solver.hybrid.surface.triangles.copy()
    with pytest.raises(SolverError, match=r"farther than 3 × its size"):
        scalpel.move(point)  # 1 m above an 8 cm cube is 6.6 sizes from its box; before: taken, the tip parked there
    assert np.array_equal(scalpel.tip, tip) and np.array_equal(solver.hybrid.surface.triangles, triangles)
    count = solver.hybrid.surface.vertex_count
    scalpel.move([0.008, 0.0, 0.08])  # the cut goes on from where it was
    assert solver.hybrid.surface.vertex_count > count
