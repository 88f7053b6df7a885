"""A method of one's own can be cut: its solver class names the updater that carries it over a cut
(``cut_carrier``), and the scalpel cuts it like the built-in methods.

The method here is a Winkler foundation: each surface vertex on a spring of its own to its rest position, so it
settles at x = rest + f / k in one step. Its updater has nothing of its own to carry: the base updater extends the
state and the loads, and every vertex is held by its spring (a piece cut loose is kept)."""

import numpy as np
import pytest

import tissuesim
from tissuesim.solvers.cut_carry import SolverCut
from tissuesim.experiments.wound import incision_line
from tissuesim.mesh import models
from tissuesim.solvers.base import Solver
from tissuesim.solvers.registry import register, unregister

STIFFNESS = 50.0  # N/m, each vertex's spring


class WinklerCut(SolverCut):
    keeps_loose = True        # every vertex has its own spring: no piece can drift

    def update(self, result, n, released, touched) -> None:
        """Nothing beyond the state and the loads, which the base updater carries."""


class Winkler(Solver):
    cut_carrier = WinklerCut

    def _step(self, dt: float) -> None:
        s = self.state
        target = self.rest_positions + self.forces / STIFFNESS
        s.velocities[:] = (target - s.positions) / dt
        s.positions[:] = target


@pytest.fixture
def winkler():
    register("winkler")(Winkler)
    yield
    unregister("winkler")


def test_a_registered_method_is_cut_by_the_scalpel_and_steps_on_the_cut_mesh(winkler):
    hybrid = tissuesim.HybridMesh.build(models.cube(400), fine_volume=False)
    solver = tissuesim.make_solver("winkler", hybrid)
    before = solver.node_count
    start, end = incision_line(solver.rest_positions, length=0.03)
    scalpel = tissuesim.Scalpel(solver, depth=0.01)
    scalpel.press(start, direction=[0.0, 0.0, -1.0])
    split = sum(scalpel.move(start + f * (end - start)).triangles_split for f in np.linspace(0.1, 1.0, 10))
    scalpel.release()
    assert split > 0 and solver.node_count > before           # the surface was cut, vertices were added
    assert solver.hybrid.surface.vertex_count == solver.node_count
    node = int(np.argmax(solver.rest_positions[:, 2]))
    solver.set_load(node, (0.0, 0.0, 0.5))
    solver.step()
    # the rule of the method holds on the cut mesh, new vertices included (assigned arithmetic: exact)
    np.testing.assert_array_equal(solver.positions, solver.rest_positions + solver.forces / STIFFNESS)
    assert solver.positions[node, 2] - solver.rest_positions[node, 2] == pytest.approx(0.5 / STIFFNESS, rel=1e-12)
