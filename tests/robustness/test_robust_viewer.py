"""Hostile input on the simulator's controller (no OpenGL): refused cuts, bad frame times, bad settings."""

import numpy as np
import pytest

from tissuesim import SolverError
from tissuesim.cli import main
from tissuesim.viewer.controller import MAX_STEPS_PER_FRAME, Controller

DOWN = np.array([0.0, 0.0, -1.0])  # a camera looking straight down on the cube's top


class Clock:
    """Advances 1 ms per reading: every step takes 1 ms of wall time, whatever the machine."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        self.now += 0.001
        return self.now


def top_centre(controller):
    x = controller.solver.positions
    return np.array([0.0, 0.0, x[:, 2].max()])


def drag(controller, points):
    """Scalpel drag through ``points`` ``(p, 3)`` [m] on the top face, the camera above."""
    controller.pointer_down(points[0], points[0] + [0.0, 0.0, 1.0], DOWN)
    for p in points[1:]:
        controller.pointer_move(p, p + [0.0, 0.0, 1.0], DOWN)


def line_across_top(controller):
    """6 points [m] of a 1 cm straight line through the top's centre (the cube is 8 cm)."""
    top = top_centre(controller)
    return [top + [dx, 0.0011, 0.0] for dx in np.linspace(-0.005, 0.005, 6)]


def cut_across_top(controller):
    """A cut along :func:`line_across_top`."""
    controller.set_mode("scalpel")
    drag(controller, line_across_top(controller))
    controller.pointer_up()


def test_a_refused_cutting_move_is_shown_and_the_session_goes_on(small_cube):
    c = Controller(small_cube, clock=Clock())
    c.set_mode("scalpel")
    top = top_centre(c)
    # a 6 mm circle: closing it would cut loose a disc that nothing holds, which the hybrid refuses
    circle = [top + [0.003 * np.cos(a), 0.003 * np.sin(a), 0.0] for a in np.linspace(0.0, 2.5 * np.pi, 31)]
    drag(c, circle)
    assert c.notice.startswith("the cut stopped here: ")  # then the method's reason (a piece cut loose)
    assert not c.scalpel.pressed                        # the blade is lifted: the next drag is not refused again
    c.pointer_up()
    assert c.advance(0.02).steps == 2                   # the simulation runs on
    c.pointer_down(circle[0], circle[0] + [0.0, 0.0, 1.0], DOWN)
    assert c.scalpel.pressed and c.notice == ""         # and a new cut can start


def test_switching_the_method_in_the_middle_of_a_cut_lifts_the_blade_and_keeps_the_cut(small_cube):
    c = Controller(small_cube, clock=Clock())
    c.set_mode("scalpel")
    line = line_across_top(c)
    drag(c, line[:3])
    cut_count = c.solver.hybrid.surface.vertex_count
    assert cut_count > small_cube.surface.vertex_count  # the first moves cut
    c.configure(method="pbd")
    for p in line[3:]:                                  # the drag goes on: the new scalpel was never pressed
        c.pointer_move(p, p + [0.0, 0.0, 1.0], DOWN)
    c.pointer_up()
    assert c.solver.name == "pbd" and c.mode == "scalpel" and not c.scalpel.pressed
    assert c.solver.hybrid.surface.vertex_count == cut_count  # the cut so far is carried, nothing more was cut


@pytest.mark.parametrize("elapsed", [float("nan"), float("inf"), -0.01, "soon"])
def test_a_bad_frame_time_is_refused_and_the_simulation_goes_on(small_cube, elapsed):
    c = Controller(small_cube, clock=Clock())
    assert c.advance(0.015).steps == 1                  # 5 ms owed to the next frame
    with pytest.raises(SolverError, match="frame's wall time"):
        c.advance(elapsed)
    # the 5 ms owed are still owed, nothing else (0.1 ms over covers the rounding of 15 ms - 10 ms)
    assert c.advance(0.0051).steps == 1 and c.advance(0.0).steps == 0


def test_a_huge_frame_time_runs_one_frame_of_steps_and_owes_less_than_one_step(small_cube):
    c = Controller(small_cube, clock=Clock())
    stats = c.advance(1e300)                            # e.g. a machine that slept: the rest is dropped, not owed
    assert stats.steps == MAX_STEPS_PER_FRAME
    # What is owed is at least nothing and less than a step: no step without more time, one with a step's more
    assert c.advance(0.0).steps == 0
    assert c.advance(c.settings.dt).steps == 1          # neither frozen nor spiralling


def test_switching_to_fem_after_a_cut_names_the_cut(small_cube):
    c = Controller(small_cube, clock=Clock())
    cut_across_top(c)
    solver = c.solver
    with pytest.raises(SolverError, match="cannot run on a cut surface") as error:
        c.configure(method="fem")
    assert "built without" not in str(error.value) and "reset" in str(error.value)
    assert c.solver is solver and c.settings.method == "hybrid"
    c.reset()                                           # the uncut mesh has its fine volume: fem runs
    c.configure(method="fem")
    assert c.solver.name == "fem"


def test_an_unknown_setting_is_a_solver_error_naming_it_and_the_valid_ones(small_cube):
    c = Controller(small_cube, clock=Clock())
    settings = c.settings
    with pytest.raises(SolverError, match="unknown setting 'bogus'") as error:
        c.configure(bogus=1, dt=0.005)
    assert "youngs_modulus" in str(error.value) and "near_field" in str(error.value)
    assert c.settings == settings and c.solver.dt == settings.dt  # the valid change beside it is not applied


@pytest.mark.parametrize("argument, said", [
    (["--stiffness", "0"], "--stiffness must be a positive finite number [N/m], got 0.0"),  # never the default
    (["--method", "magic"], "unknown method 'magic'"),
    (["--prestrain", "0.9"], "prestrain"),
])
def test_view_refuses_a_bad_argument_in_one_line_before_building_anything(capsys, argument, said):
    assert main(["view", "cube", *argument]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and said in err and "building" not in err


def test_a_click_on_the_support_holds_the_nearest_free_node_and_says_so(small_cube):
    c = Controller(small_cube, clock=Clock())
    solver = c.solver
    lowest_fixed = solver.fixed[np.argmin(solver.positions[solver.fixed, 2])]
    point = solver.positions[lowest_fixed].copy()
    c.pointer_down(point, point + [0.0, 0.0, 1.0], DOWN)
    assert c.pin.grabbed and c.pin.node not in solver.fixed
    assert c.notice == c.pin.notice and f"node {lowest_fixed}" in c.notice


def test_view_takes_a_built_in_name_over_a_file_of_that_name(tmp_path, monkeypatch):
    from tissuesim.commands.view import load_hybrid

    monkeypatch.chdir(tmp_path)
    (tmp_path / "cube").write_text("not a bundle")           # a stray file named like the built-in model
    hybrid, name = load_hybrid("cube", resolution=200, progress=False)
    assert name == "cube" and hybrid.surface.vertex_count > 0
