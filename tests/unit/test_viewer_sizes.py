"""The simulator's tools sized to the model: a drag of a tenth of its size stays in small strain on every built-in
model, and the sizes scale with the model and the material."""

import numpy as np
import pytest

from tissuesim import HybridMesh, PinHead, make_solver
from tissuesim.mesh import models
from tissuesim.viewer.settings import DRAG_FRACTION, sized_defaults


def test_sized_tools_scale_as_the_model_and_the_material():
    points = models.cube().vertices
    base = sized_defaults(points)
    double = sized_defaults(2.0 * points)
    stiffer = sized_defaults(points, youngs_modulus=11000.0)
    assert double.radius == pytest.approx(2.0 * base.radius, rel=1e-2)       # lengths ∝ L (3 significant digits)
    assert double.depth == pytest.approx(2.0 * base.depth, rel=1e-2)
    assert double.stiffness == pytest.approx(2.0 * base.stiffness, rel=1e-2)  # k ∝ E L: a force ∝ E L² per drag ∝ L
    assert stiffer.stiffness == pytest.approx(2.0 * base.stiffness, rel=1e-2)


@pytest.mark.parametrize("name", sorted(models.MODELS))
def test_a_drag_of_a_tenth_of_the_model_stays_in_small_strain(name):
    hybrid = HybridMesh.build(models.MODELS[name](resolution=400))
    solver = make_solver("hybrid", hybrid)
    sized = sized_defaults(hybrid.surface.vertices, edge_length=hybrid.surface.mean_edge_length)
    pin = PinHead(solver, stiffness=sized.stiffness, radius=sized.radius)
    x = solver.rest_positions
    upper = x[:, 2] >= np.quantile(x[:, 2], 0.9)     # the top, near the vertical axis: where a user grabs first
    top = x[upper][np.argmin(np.linalg.norm(x[upper, :2] - x[:, :2].mean(axis=0), axis=1))]
    pin.grab(top)
    pin.drag(pin.anchor + [0.0, 0.0, DRAG_FRACTION * solver.size])
    solver.solve_static()
    assert solver.warning is None, solver.warning       # largest displacement below the linear-validity fraction
    assert solver.largest_displacement > 1e-3 * solver.size  # and the drag shows
