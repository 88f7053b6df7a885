"""The viewer's material setting: a finite-strain hybrid under a 5 cm pin-head drag on the liver stays finite, turns
no element inside out, and follows the pin-head; the setting rebuilds the solver and reaches only the methods that
have it."""

import numpy as np
import pytest

import tissuesim
from tissuesim.errors import MaterialError
from tissuesim.mesh.tetmesh import tet_signed_volumes
from tissuesim.viewer.controller import Controller, Settings

DOWN = np.array([0.0, 0.0, -1.0])


@pytest.fixture(scope="module")
def liver():
    return tissuesim.HybridMesh.build(tissuesim.models.liver(), fine_volume=False)


def _drag(controller, distance, frames=40):
    """Grab the highest node, move the cursor ``distance`` [m] sideways (screen plane), run ``frames`` frames."""
    x = controller.solver.positions
    top = x[np.argmax(x[:, 2])].copy()
    controller.pointer_down(top, top + [0, 0, 0.5], DOWN)
    controller.pointer_move(None, top + [distance, 0.0, 0.5], DOWN)
    for _ in range(frames):
        controller.advance(0.02)
    return controller.pin.node, top


def test_a_5_cm_drag_on_the_liver_stays_finite_and_turns_no_element_or_triangle_inside_out(liver, flipped_triangles):
    c = Controller(liver, settings=Settings(material="neo-hookean", stiffness=20.0))
    assert c.solver.material == "neo-hookean"
    node, top = _drag(c, 0.05)
    solver = c.solver
    assert np.all(np.isfinite(solver.positions))
    volumes = tet_signed_volumes(solver.finite.rest + solver.volume_displacement, solver.finite.elements)
    assert volumes.min() > 0.0
    assert flipped_triangles(solver.positions, liver.surface.triangles) == 0
    moved = solver.positions[node] - top
    assert 0.0 < moved[0] < 0.05 and abs(moved[1]) < moved[0]     # toward the pin-head, never past it


def test_the_material_setting_rebuilds_and_reaches_only_methods_that_have_it(liver):
    c = Controller(liver)
    assert c.solver.material == "linear"
    c.configure(material="corotated")
    assert c.solver.material == "corotated"
    c.configure(method="mass-spring")
    assert c.solver.material == "linear" and not c.finite_strain_available()
    with pytest.raises(MaterialError, match="unknown material"):
        c.configure(material="rubber")
