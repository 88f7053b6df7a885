"""Cutting a finite-strain model: the solvers absorb the topology change and keep stepping to a finite state."""

import numpy as np
import pytest

import tissuesim
from tissuesim.experiments.wound import incision_line
from tissuesim.solvers import method_names


@pytest.fixture(scope="module")
def cube():
    return tissuesim.HybridMesh.build(tissuesim.models.cube())


@pytest.mark.parametrize("method", method_names(cuts=True, material="neo-hookean"))
def test_a_held_pull_and_an_incision_beside_it_keep_a_finite_strain_model_finite(cube, method):
    solver = tissuesim.make_solver(method, cube, material="neo-hookean")
    start, end = incision_line(solver.rest_positions)
    pin = tissuesim.PinHead(solver, stiffness=20.0)
    pin.grab(0.5 * (start + end) + [0.0, 0.006, -0.001])
    pin.drag(pin.anchor + [0.0, 0.02, 0.01])
    for _ in range(5):
        solver.step()
    scalpel = tissuesim.Scalpel(solver, depth=0.01)
    scalpel.press(start, direction=[0, 0, -1])
    split = 0
    for f in np.linspace(0, 1, 8)[1:]:
        split += scalpel.move(start + f * (end - start)).triangles_split
        solver.step()
    scalpel.release()
    assert split > 0
    for _ in range(100):
        solver.step()
    assert np.all(np.isfinite(solver.positions))
    assert solver.largest_displacement < 0.5 * solver.size
