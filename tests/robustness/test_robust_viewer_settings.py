"""The controller's settings and pointer events under hostile values: a refused change or event changes nothing."""

import numpy as np
import pytest

from tissuesim import SolverError
from tissuesim.viewer.controller import Controller, Settings

DOWN = np.array([0.0, 0.0, -1.0])  # a camera looking straight down on the cube's top


def top_centre(controller):
    """The centre of the cube's top [m]."""
    return np.array([0.0, 0.0, controller.solver.positions[:, 2].max()])


def held_drag(controller):
    """Grab the top centre and drag 1 cm along x in the camera plane; returns the top point [m]."""
    top = top_centre(controller)
    controller.pointer_down(top, top + [0.0, 0.0, 0.3], DOWN)
    controller.pointer_move(None, top + [0.01, 0.0, 0.3], DOWN)
    assert controller.pin.grabbed and controller.solver.load is not None
    return top


def test_a_refused_method_change_keeps_the_solver_the_pin_head_and_its_load(small_cube):
    c = Controller(small_cube)
    held_drag(c)
    solver, pin, settings, force = c.solver, c.pin, c.settings, c.force.copy()
    load = (solver.load[0], solver.load[1].copy())
    with pytest.raises(SolverError, match="reaches the fixed region"):
        c.configure(method="pbd", radius=0.2)  # 0.2 m around the held node covers the 8 cm cube's support
    assert c.solver is solver and c.pin is pin and c.settings == settings
    assert pin.radius is None and pin.node == load[0] and np.array_equal(c.force, force)
    assert solver.load[0] == load[0] and np.array_equal(solver.load[1], load[1])  # assigned values: exact


@pytest.mark.parametrize("change", [
    {"dt": "0.02"}, {"stiffness": "5"}, {"youngs_modulus": True}, {"poisson_ratio": "0.3"},
    {"iterations": 2.5}, {"iterations": True}, {"prestrain": False}, {"near_field": "0.01"},
])
def test_a_setting_that_is_a_string_a_bool_or_a_fraction_of_an_iteration_is_refused_by_name(small_cube, change):
    c = Controller(small_cube)
    solver, settings = c.solver, c.settings
    with pytest.raises(SolverError, match=f"setting {next(iter(change))} "):
        c.configure(**change)
    assert c.solver is solver and c.settings == settings
    with pytest.raises(SolverError, match=f"setting {next(iter(change))} "):
        Controller(small_cube, settings=Settings(**change))


def test_settings_are_stored_as_numbers(small_cube):
    c = Controller(small_cube, settings=Settings(method="pbd", iterations=np.int64(3), dt=np.float32(0.005)))
    assert type(c.settings.iterations) is int and c.settings.iterations == 3
    assert type(c.settings.dt) is float and type(c.settings.youngs_modulus) is float


def test_a_bool_is_no_frame_time(small_cube):
    c = Controller(small_cube)
    with pytest.raises(SolverError, match="frame's wall time"):
        c.advance(True)  # would be 1 s: a whole frame of steps
    assert c.advance(0.0).steps == 0


@pytest.mark.parametrize("origin_shift, direction", [
    ([0.01, 0.0, 0.3], [0.0, 0.0, 0.0]),        # a zero ray
    ([0.01, 0.0, 0.3], [np.nan, 0.0, 0.0]),     # a NaN ray
    ([1e300, 0.0, 0.3], [0.0, 0.0, -1.0]),      # a drag whose force k (x - x0) overflows |f|^2
])
def test_a_drag_the_pin_head_refuses_keeps_the_hold_and_says_why(small_cube, origin_shift, direction):
    c = Controller(small_cube)
    top = held_drag(c)
    node, force = c.pin.node, c.force.copy()
    load = c.solver.load[1].copy()
    c.pointer_move(None, top + origin_shift, direction)   # raised out of the controller before
    assert c.notice.startswith("the drag was refused: ")
    assert c.pin.node == node and np.array_equal(c.force, force) and np.array_equal(c.solver.load[1], load)
    c.pointer_move(None, top + [0.02, 0.0, 0.3], DOWN)    # the next good drag goes on
    assert c.force[0] > force[0]


def test_bad_pointer_and_key_events_are_shown_not_raised(small_cube):
    c = Controller(small_cube)
    c.pointer_down("abc", [0.0, 0.0, 1.0], DOWN)
    assert "3 numbers" in c.notice and not c.pin.grabbed
    c.key(["s"])
    assert "got ['s']" in c.notice and c.mode == "pin"
    c.set_mode("scalpel")
    top = top_centre(c)
    c.pointer_down(top, top + [0.0, 0.0, 0.3], [0.0, 0.0, 0.0])  # the blade is lifted along the ray: none here
    assert "camera ray" in c.notice and not c.scalpel.pressed
