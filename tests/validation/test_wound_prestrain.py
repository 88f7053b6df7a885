"""A prestrained cut gapes as a wound, not as a hanging flap: with ε = 5 % and no force, the scripted 30 mm
incision opens along its length, and no lip opens more than 3 times the median opening. Before the cut followed
the blade, the zig-zag left teeth (a lip vertex whose every neighbour was on the cut) that swung out: 7.1 times
the median on the sphere, 10.6 on the liver (hybrid; benchmarks/wound_figures.py draws them)."""

import numpy as np
import pytest

import tissuesim
from tissuesim.experiments.wound import scripted_incision, unloaded_openings
from tissuesim.mesh import models

#: the steak: a lip vertex next to the wound's end is held by one edge off the lip, at 25° to it, and the linear
#: layer's edges give it almost no stiffness across the lip, so the released tension swings it 7.7 times the median
STEAK = pytest.mark.xfail(reason="a lip vertex held by a single edge at a shallow angle, next to the wound's end, "
                                 "swings 7.7 times the median opening (hybrid)", strict=True)


@pytest.mark.parametrize("name", ["cube", "sphere", "liver", pytest.param("steak", marks=STEAK)])
def test_a_prestrained_wound_gapes_along_its_length_without_a_hanging_flap(name):
    hybrid = tissuesim.HybridMesh.build(models.model(name), fine_volume=False)
    solver = tissuesim.make_solver("hybrid", hybrid, prestrain=0.05)
    line = scripted_incision(solver)["line"]
    openings = unloaded_openings(solver, line)
    median = float(np.median(openings))
    assert median > 0.5e-3                                   # it gapes: 1.2–2.0 mm measured
    assert openings.max() <= 3.0 * median, (openings.max(), median)
