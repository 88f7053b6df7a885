"""Mass-spring after a cut: a flap on the cut's lip that swings past a right angle is not a triangle turned inside out.

The method refuses a step that turns a triangle's normal against its rest normal, since springs cannot turn an
inverted triangle back. On an uncut surface no piece can swing that far under a moderate load; on a cut one, a flap
on the lip can, as a whole, with each of its hinges bent far less (measured: 90° with folds of 34° and 52° under
0.3 N), and its springs bring it back. Such steps were refused: 0.3 N on the 29 free new vertices of the cube's rim
cut, in 6 directions each, was refused at 84 of the 174 pairs (now 2, folded over a neighbour), and in 2 of 102
random cutting episodes with 0.3 N on a new vertex (now none); the uncut surface carries the same loads. Rest
lengths (1e-9), masses (by lumped area, the total kept) and springs (the same set as a fresh build of the cut
surface) were all right: the check was wrong.
"""

import numpy as np
import pytest

import tissuesim
from test_robust_cut_flap import rim_cut
from tissuesim.mesh import models
from tissuesim.solvers.mass_spring import inverted_triangles


@pytest.fixture(scope="module")
def cube():
    return tissuesim.HybridMesh.build(models.cube(), fine_volume=False)


@pytest.fixture
def cut_solver(cube):
    solver = tissuesim.make_solver("mass-spring", cube)
    rim_cut(solver)
    return solver


def _first_lip_vertex(solver, cube):
    """The first vertex the cut added that is free to move."""
    new = np.arange(cube.surface.vertex_count, solver.node_count)
    return int(new[~np.isin(new, solver.fixed)][0])


def test_a_flap_on_the_lip_swings_past_a_right_angle_and_comes_back(cube, cut_solver):
    solver = cut_solver
    node = _first_lip_vertex(solver, cube)
    solver.set_load(node, [0.0, 0.3, 0.0])
    swung = 0
    for _ in range(30):
        solver.step()       # refused before: "turned 1 triangles inside out"
        swung = max(swung, inverted_triangles(solver.rest_positions, solver.positions,
                                              solver.hybrid.surface.triangles)[0])
    assert swung > 0        # the flap did turn triangles past a right angle from rest
    solver.clear_load()
    for _ in range(300):
        solver.step()
    # Springs pull it back: no triangle against its rest normal. The lip's restoring force is of second order in the
    # swing (its springs lie in the plane at rest), so it creeps back: 0.61 mm after 3 s, 0.23 mm after 30 s.
    assert inverted_triangles(solver.rest_positions, solver.positions, solver.hybrid.surface.triangles)[0] == 0
    assert np.abs(solver.displacements).max() < 1e-3


def test_a_triangle_folded_over_on_a_cut_surface_is_still_refused(cube, cut_solver):
    solver = cut_solver
    node = _first_lip_vertex(solver, cube)
    solver.set_load(node, [0.0, 0.0, -10.0])       # 10 N folds the lip over its neighbours
    with pytest.raises(tissuesim.InversionError, match="inside out.*lower the force"):
        for _ in range(30):
            solver.step()
