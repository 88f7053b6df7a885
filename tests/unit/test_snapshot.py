"""Snapshot.restore leaves a solver stepping exactly as a twin that never did the work in between (the haptic
loop's local solves, a refused probe press), finite strain, gravity and the quadratic M_V included."""

import numpy as np
import pytest

import tissuesim
from tissuesim.experiments.protocol import load_node
from tissuesim.mesh import models
from tissuesim.solvers.snapshot import Snapshot


@pytest.fixture(scope="module")
def cube():
    return tissuesim.HybridMesh.build(models.cube(400))


@pytest.mark.parametrize("options", [{"material": "neo-hookean"}, {"material": "neo-hookean", "element": "quadratic"},
                                     {}])
def test_after_a_restore_the_steps_are_the_twins(cube, options):
    node = load_node(cube.surface.vertices, cube.surface.triangles)
    first, twin = (tissuesim.make_solver("hybrid", cube, gravity=(0.0, 0.0, -9.81), **options) for _ in range(2))
    for solver in (first, twin):
        solver.set_load(node, [0.0, 0.0, -0.1], radius=0.008)
        solver.step()
        solver.step()
    snapshot = Snapshot(first)
    first.solve_static(node, [0.05, 0.0, 0.0], radius=0.008)      # the work a snapshot takes back
    snapshot.restore(first)
    for _ in range(4):
        first.step()
        twin.step()
        assert np.array_equal(first.positions, twin.positions)     # the same arithmetic: bit for bit
