"""N1: every entry point of a probe sees the surface as it is now. A cut adds vertices; the probe's per-vertex areas
and triangle spans of the uncut surface made ``update()`` (a haptic device's call each tick) raise IndexError after
any cut, on every method that cuts."""

import numpy as np
import pytest

from tissuesim import Scalpel, make_solver
from tissuesim.tools.probe import Probe
from tissuesim.solvers import method_names

CUTTING = method_names(cuts=True)
RADIUS = 0.012      # [m] the probe: larger than the small cube's triangles
TOP = 0.08          # [m] the cube's top


def pressed_then_cut(small_cube, method):
    """A solver, a probe pressing 1 mm into the top's centre, a step, then a 4 cm cut beside the probe."""
    solver = make_solver(method, small_cube)
    probe = Probe(solver, radius=RADIUS)
    with pytest.warns(Warning):      # the small cube's triangles may sink into the probe: said once
        probe.move_to([0.0, 0.0, TOP + RADIUS - 0.001])
    solver.step()
    count = solver.node_count
    scalpel = Scalpel(solver, depth=0.01)
    scalpel.press([-0.0201, 0.0053, TOP], direction=[0, 0, -1])
    for x in (-0.0101, -0.0002, 0.0099, 0.0199):
        scalpel.move([x, 0.0053, TOP])
    assert solver.node_count > count          # the cut added vertices: the surface the probe knew is gone
    return solver, probe


@pytest.mark.parametrize("method", CUTTING)
def test_a_held_probe_updates_after_a_cut(small_cube, method):
    solver, probe = pressed_then_cut(small_cube, method)
    probe.update()
    solver.step()
    assert probe.contacts.size > 0 and probe.force[2] > 0.0      # still pressing, upward on the probe
    assert probe.gaps().shape == (solver.node_count,)


@pytest.mark.parametrize("method", CUTTING)
def test_every_probe_entry_point_works_after_a_cut(small_cube, method):
    solver, probe = pressed_then_cut(small_cube, method)
    centre = [0.001, 0.0, TOP + RADIUS - 0.001]
    probe.move_to(centre)
    solver.step()
    probe.settle(centre)
    probe.press_static(centre)
    assert probe.residual <= probe.tolerance
    assert probe.force[2] > 0.0 and np.all(np.isfinite(probe.force))
