"""N20, the instruments: every numeric argument of the probe, the pin-head and the scalpel, and of their moves, presses
and grabs, refuses text (``Probe(s, radius="5")`` was a 5 m probe; a blade direction ["0", "0", "-1"] and a snap
"0.2" were read as numbers), naming the argument; a refused call changes nothing."""

import numpy as np
import pytest

from tissuesim import PinHead, Scalpel, SolverError, make_solver
from tissuesim.tools.probe import Probe

TOP = [0.0, 0.0, 0.08]          # [m] the small cube's top centre
ABOVE = [0.0, 0.0, 0.091]       # [m] a 12 mm probe's centre, 1 mm into the top


@pytest.fixture
def solver(small_cube):
    return make_solver("hybrid", small_cube)


def grabbed(solver):
    pin = PinHead(solver, stiffness=20.0)
    pin.grab(TOP)
    return pin


def pressed(solver):
    scalpel = Scalpel(solver, depth=0.01)
    scalpel.press([0.0013, 0.0011, 0.08])
    return scalpel


CALLS = {
    "probe radius": (r"probe radius must be a number", lambda s: Probe(s, radius="0.012")),
    "probe tolerance": (r"contact tolerance must be a number", lambda s: Probe(s, radius=0.012, tolerance="1e-5")),
    "probe centre": (r"probe centre must be 3 numbers", lambda s: Probe(s, radius=0.012).move_to(["0", "0", "0.091"])),
    "capsule end": (r"capsule end must be 3 numbers",
                    lambda s: Probe(s, radius=0.012).settle(ABOVE, end=["0.01", "0", "0.091"])),
    "press centre": (r"probe centre must be 3 numbers", lambda s: Probe(s, radius=0.012).press_static("0 0 0.091")),
    "press iterations": (r"max_iterations must be a whole number",
                         lambda s: Probe(s, radius=0.012).press_static(ABOVE, max_iterations="5")),
    "press steps": (r"max_steps must be a whole number",
                    lambda s: Probe(s, radius=0.012).press_static(ABOVE, max_steps="100")),
    "settle iterations": (r"max_iterations must be a whole number",
                          lambda s: Probe(s, radius=0.012).settle(ABOVE, max_iterations="8")),
    "pin-head stiffness": (r"pin-head stiffness must be a number", lambda s: PinHead(s, stiffness="20")),
    "snap radius": (r"snap radius must be a number", lambda s: PinHead(s, stiffness=20.0, snap_radius="0.02")),
    "contact radius": (r"contact radius must be a number", lambda s: PinHead(s, stiffness=20.0, radius="0.004")),
    "grab point": (r"must be 3 numbers", lambda s: PinHead(s, stiffness=20.0).grab(["0", "0", "0.08"])),
    "drag point": (r"must be 3 numbers", lambda s: grabbed(s).drag(["0", "0", "0.09"])),
    "blade depth": (r"blade depth must be a number", lambda s: Scalpel(s, depth="0.01")),
    "snap": (r"snap option must be a fraction .* got '0.2'", lambda s: Scalpel(s, snap="0.2")),
    "press point": (r"must be 3 numbers", lambda s: Scalpel(s, depth=0.01).press(["0", "0", "0.08"])),
    "blade direction": (r"blade direction must be 3 finite numbers",
                        lambda s: Scalpel(s, depth=0.01).press(TOP, direction=["0", "0", "-1"])),
    "move point": (r"must be 3 numbers", lambda s: pressed(s).move(["0.01", "0", "0.08"])),
}


@pytest.mark.parametrize("name", CALLS)
def test_the_instruments_refuse_numbers_given_as_text(solver, name):
    message, call = CALLS[name]
    count = solver.node_count
    with pytest.raises(SolverError, match=message):
        call(solver)
    assert solver.loads == () and solver.node_count == count
    assert np.array_equal(solver.positions, solver.rest_positions)
