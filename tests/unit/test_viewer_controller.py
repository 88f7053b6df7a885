"""The simulator's interaction logic without OpenGL: pointer events → PinHead / Scalpel, settings, fixed-dt time."""

import numpy as np
import pytest

from tissuesim import HybridMesh, SolverError
from tissuesim.mesh import models
from tissuesim.viewer import controller as controller_module
from tissuesim.viewer.controller import BLADE_LIFT, MAX_STEPS_PER_FRAME, Controller, Settings, camera_plane_point

DOWN = np.array([0.0, 0.0, -1.0])  # a camera looking straight down


@pytest.fixture(scope="module")
def hybrid():
    return HybridMesh.build(models.sphere(resolution=200))


class FakeScalpel:
    """Records the calls the controller makes; stands in for tissuesim.Scalpel's press / move / release."""

    depth = 0.01  # blade length [m]

    def __init__(self, solver):
        self.solver, self.calls = solver, []

    def press(self, point, direction=None):
        self.calls.append(("press", np.array(point), direction))
        return {"cut": 0}

    def move(self, point):
        self.calls.append(("move", np.array(point)))
        return {"cut": len(self.calls)}

    def release(self):
        self.calls.append(("release",))
        return {"cut": len(self.calls)}


class Clock:
    """A clock that advances by a fixed wall time per reading, so every step takes exactly that long."""

    def __init__(self, step_seconds):
        self.now, self.step_seconds = 0.0, step_seconds

    def __call__(self):
        self.now += self.step_seconds
        return self.now


def top_of(controller):
    x = controller.solver.positions
    return x[np.argmax(x[:, 2])].copy()


def above(point, height=0.5):
    return point + [0.0, 0.0, height]


def test_camera_plane_point_moves_parallel_to_the_screen():
    anchor = np.array([0.1, 0.2, 0.3])
    point = camera_plane_point([0.15, 0.2, 1.0], DOWN, anchor)
    assert np.allclose(point, [0.15, 0.2, 0.3])  # same depth as the anchor, under the cursor
    assert camera_plane_point([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]) is None  # behind the camera


def test_press_drag_release_applies_eq24_in_the_camera_plane_and_withdraws_it(hybrid):
    c = Controller(hybrid, settings=Settings(stiffness=40.0))
    top = top_of(c)
    c.pointer_down(top, above(top), DOWN)
    node = c.pin.node
    assert node is not None and c.solver.load is None  # a grab alone applies no force
    c.pointer_move(None, above(top + [0.01, 0.0, 0.0]), DOWN)  # the cursor slides 1 cm sideways on screen
    assert np.allclose(c.force, [0.4, 0.0, 0.0])  # k (x − x0), x in the plane through the grab point
    assert c.solver.load[0] == node and np.allclose(c.solver.load[1], c.force)
    c.advance(0.05)
    assert c.solver.positions[node, 0] > hybrid.surface.vertices[node, 0]
    c.pointer_up()
    assert c.solver.load is None and c.force_newtons == 0.0 and not c.pin.grabbed


def test_a_press_beside_the_surface_grabs_nothing_and_says_why(hybrid):
    c = Controller(hybrid)
    c.pointer_down(None, [0.0, 0.0, 1.0], DOWN)  # nothing picked: the camera turns instead
    assert not c.pin.grabbed and c.notice == ""
    c.pointer_down(top_of(c) + [0.0, 0.0, 0.3], [0.0, 0.0, 1.0], DOWN)  # a point far from every node
    assert not c.pin.grabbed and "nothing to grab" in c.notice


def test_hover_moves_the_pin_head_with_the_cursor(hybrid):
    c = Controller(hybrid)
    top = top_of(c)
    c.pointer_move(top, above(top), DOWN)
    assert np.array_equal(c.cursor, top) and c.solver.load is None


def test_scalpel_mode_turns_press_move_release_into_scalpel_calls(hybrid):
    c = Controller(hybrid, scalpel_factory=FakeScalpel)
    c.key("s")
    assert c.mode == "scalpel"
    top = top_of(c)
    c.pointer_down(top, above(top), DOWN)
    c.pointer_move(top + [0.005, 0.0, 0.0], above(top), DOWN)
    c.pointer_move(None, above(top + [0.01, 0.0, 0.0]), DOWN)  # off the surface: the camera-plane point
    c.pointer_up()
    calls = c.scalpel.calls
    lift = np.array([0.0, 0.0, BLADE_LIFT * FakeScalpel.depth])  # the tip above the picked point, toward the camera
    assert [call[0] for call in calls] == ["press", "move", "move", "release"]
    assert np.allclose(calls[0][1], top + lift) and calls[0][2] is None  # the blade along the inward normal
    assert np.allclose(calls[1][1], top + [0.005, 0.0, 0.0] + lift)
    assert np.allclose(calls[2][1], top + [0.01, 0.0, 0.0] + lift)  # off the surface: the plane through the tip
    assert c.last_cut == {"cut": 4} and c.solver.load is None


def test_scalpel_mode_is_refused_with_a_notice_where_no_scalpel_exists(hybrid, monkeypatch):
    monkeypatch.setattr(controller_module, "scalpel_class", lambda: None)  # an installation without Scalpel
    c = Controller(hybrid)
    c.set_mode("scalpel")
    assert c.mode == "pin" and "Scalpel" in c.notice and not c.scalpel_available


def test_a_method_that_cannot_be_cut_falls_back_to_the_pin_head_and_says_why(hybrid):
    def scalpel_unless_fem(solver):
        if solver.name == "fem":
            raise SolverError("the fem reference cannot be cut")
        return FakeScalpel(solver)

    c = Controller(hybrid, scalpel_factory=scalpel_unless_fem)
    c.set_mode("scalpel")
    c.configure(method="fem")
    assert c.mode == "pin" and not c.scalpel_available
    c.set_mode("scalpel")
    assert c.mode == "pin" and "cannot be cut" in c.notice
    c.configure(method="hybrid")
    c.set_mode("scalpel")
    assert c.mode == "scalpel"


def test_switching_mode_releases_a_held_pin_head(hybrid):
    c = Controller(hybrid, scalpel_factory=FakeScalpel)
    top = top_of(c)
    c.pointer_down(top, above(top), DOWN)
    c.pointer_move(None, above(top + [0.0, 0.01, 0.0]), DOWN)
    c.toggle_mode()
    assert c.mode == "scalpel" and c.solver.load is None


def test_method_switch_is_live_and_keeps_the_held_load(hybrid):
    c = Controller(hybrid, settings=Settings(stiffness=40.0))
    top = top_of(c)
    c.pointer_down(top, above(top), DOWN)
    c.pointer_move(None, above(top + [0.01, 0.0, 0.0]), DOWN)
    node = c.pin.node
    c.configure(method="pbd")
    assert c.solver.name == "pbd" and c.solver.load[0] == node and np.allclose(c.solver.load[1], [0.4, 0.0, 0.0])


def test_settings_reach_the_solver_and_pin_head(hybrid):
    c = Controller(hybrid)
    c.configure(youngs_modulus=11000.0, poisson_ratio=0.45, iterations=4, dt=0.005, stiffness=80.0)
    # exact: the settings as assigned
    assert c.solver.youngs_modulus == 11000.0 and c.solver.poisson_ratio == 0.45
    assert c.solver.iterations == 4 and c.solver.dt == 0.005 and c.pin.stiffness == 80.0
    c.configure(method="embedded")  # a method without iterations keeps working
    assert c.solver.name == "embedded"


def test_a_bad_setting_changes_nothing(hybrid):
    c = Controller(hybrid)
    solver = c.solver
    with pytest.raises(SolverError, match="dt"):
        c.configure(dt=-1.0)
    with pytest.raises(SolverError, match="unknown method"):
        c.configure(method="magic")
    assert c.solver is solver and c.settings == Settings()


def test_reset_returns_to_rest_without_load(hybrid):
    c = Controller(hybrid)
    top = top_of(c)
    c.pointer_down(top, above(top), DOWN)
    c.pointer_move(None, above(top + [0.0, 0.02, 0.0]), DOWN)
    c.advance(0.1)
    c.key("r")
    assert c.solver.load is None and np.array_equal(c.solver.positions, hybrid.surface.vertices)


def test_advance_runs_the_steps_wall_time_asks_for_at_fixed_dt(hybrid):
    c = Controller(hybrid, clock=Clock(0.001))
    assert c.advance(0.035).steps == 3  # 35 ms at dt = 10 ms: 3 steps, 5 ms carried to the next frame
    assert c.advance(0.005).steps == 1
    stats = c.advance(1.0)  # a long stall: at most MAX_STEPS_PER_FRAME, the rest is dropped, not owed
    assert stats.steps == MAX_STEPS_PER_FRAME and stats.dropped > 0.7 and not stats.behind
    assert c.advance(0.0).steps == 0


def test_a_step_slower_than_dt_is_reported_behind(hybrid):
    c = Controller(hybrid, clock=Clock(0.02))  # every step takes 20 ms of wall time, dt is 10 ms
    stats = c.advance(0.02)
    assert stats.behind and stats.step_seconds == pytest.approx(0.02)


def test_pause_stops_time(hybrid):
    c = Controller(hybrid)
    c.key("space")
    assert c.advance(0.1).steps == 0
    c.key("space")
    assert c.advance(0.01).steps == 1


def test_the_contact_radius_spreads_the_held_load_and_a_bad_one_changes_nothing(hybrid):
    c = Controller(hybrid, settings=Settings(radius=0.03))  # 3 cm on a 10 cm sphere of ~2 cm edges
    assert c.pin.radius == 0.03
    top = top_of(c)
    c.pointer_down(top, above(top), DOWN)
    c.pointer_move(None, above(top + [0.01, 0.0, 0.0]), DOWN)
    spread = np.count_nonzero(np.any(c.solver.forces, axis=1))
    c.configure(radius=None)
    assert c.pin.radius is None and np.count_nonzero(np.any(c.solver.forces, axis=1)) == 1 < spread
    with pytest.raises(SolverError):
        c.configure(radius=1.0)  # a 1 m tip reaches the fixed bottom
    assert c.settings.radius is None and c.pin.radius is None and c.pin.grabbed


def test_a_bundle_opens_as_saved_and_the_fem_method_says_what_it_lacks(tmp_path):
    from tissuesim.commands.view import load_hybrid

    HybridMesh.build(models.cube(resolution=150), fine_volume=False).save(tmp_path / "cube.npz")
    hybrid, name = load_hybrid(str(tmp_path / "cube.npz"))
    assert name == "cube" and hybrid.fine_volume is None
    c = Controller(hybrid)
    with pytest.raises(SolverError, match="fine volume"):
        c.configure(method="fem")
    assert c.solver.name == "hybrid"


def test_a_step_that_fails_is_reported_and_the_simulation_restarts_at_rest(hybrid, monkeypatch):
    c = Controller(hybrid, clock=Clock(0.001))
    top = top_of(c)
    c.pointer_down(top, above(top), DOWN)
    c.pointer_move(None, above(top + [0.01, 0.0, 0.0]), DOWN)

    def fail(dt=None):
        raise SolverError("the surface turned inside out")

    monkeypatch.setattr(c.solver, "step", fail)
    c.advance(0.05)  # the window's frame callback must not die with the solver
    assert "inside out" in c.notice and not c.pin.grabbed and c.solver.load is None
    np.testing.assert_array_equal(c.solver.positions, hybrid.surface.vertices)


def test_prestrain_reaches_the_methods_that_take_one_and_a_cut_gapes_in_the_viewer(hybrid):
    from tissuesim.experiments.wound import wound_gap

    c = Controller(hybrid, settings=Settings(prestrain=0.05))
    assert c.solver.prestrain == 0.05
    c.key("s")
    top = top_of(c)
    c.pointer_down(top + [-0.01, 0.001, 0.0], above(top), DOWN)
    for dx in np.linspace(-0.01, 0.01, 6)[1:]:
        c.pointer_move(top + [dx, 0.001, 0.0], above(top), DOWN)
    c.pointer_up()
    c.advance(0.5)
    assert wound_gap(c.solver) > 1e-4                       # open with no force on it
    c.configure(method="embedded")                          # a method without a surface layer takes none
    assert c.solver.name == "embedded" and c.settings.prestrain == 0.05
    for bad in (0.9, "0.05"):
        with pytest.raises(SolverError, match="prestrain"):
            c.configure(prestrain=bad)
    assert c.settings.prestrain == 0.05


def test_the_near_field_is_a_setting_and_a_cut_in_the_viewer_switches_it_off(hybrid):
    c = Controller(hybrid, settings=Settings(near_field=0.015))
    assert c.solver.near_field == 0.015 and c.near_field_available()   # the scalpel, built already, cut nothing yet
    top = top_of(c)
    c.pointer_down(top, above(top), DOWN)
    c.pointer_move(top + [0.0, 0.0, 0.005], above(top), DOWN)
    c.advance(0.1)
    assert c.solver.near_window.size > 0                                   # the grab prescribed its window
    c.pointer_up()
    c.configure(near_field=None)
    assert c.solver.near_field is None
    c.configure(near_field=0.015)
    c.key("s")
    with pytest.warns(UserWarning, match="near field"):
        c.pointer_down(top + [-0.01, 0.001, 0.0], above(top), DOWN)
        for dx in np.linspace(-0.01, 0.01, 6)[1:]:
            c.pointer_move(top + [dx, 0.001, 0.0], above(top), DOWN)
        c.pointer_up()
    assert c.solver.near_field is None and not c.near_field_available()
    c.configure(iterations=5)                                          # a rebuild on the cut mesh leaves it off
    assert c.solver.near_field is None and c.settings.near_field == 0.015
    for bad in (-1.0, "far"):
        with pytest.raises(SolverError, match="near field W"):
            c.configure(near_field=bad)


def test_picking_up_the_scalpel_starts_building_the_first_cut_factor(hybrid):
    c = Controller(hybrid)
    c.advance(0.05)                          # the layer is factorised by its first steps
    statics = c.solver.built_statics
    assert getattr(statics, "cut_base", None) is None
    c.set_mode("scalpel")
    assert statics.cut_base.result() is not None    # built while the user aims, before any press


def test_the_quadratic_m_v_is_a_setting_that_replaces_the_near_field(hybrid):
    c = Controller(hybrid, settings=Settings(near_field=0.015))
    c.configure(element="quadratic", near_field=None)
    assert c.solver.element == "quadratic" and c.solver.near_field is None and not c.near_field_available()
    with pytest.raises(SolverError, match="drop near_field"):
        c.configure(near_field=0.015)
    assert c.solver.element == "quadratic" and c.settings.near_field is None      # refused: nothing changed
    with pytest.raises(SolverError, match="element must be one of"):
        c.configure(element="cubic")
    c.configure(method="pbd")
    assert not c.element_available() and c.solver.name == "pbd"       # pbd has no M_V: the setting waits
    c.configure(method="hybrid")
    assert c.solver.element == "quadratic"


class TextsImGui:
    """Stands in for polyscope's ImGui module: keeps the texts the panel writes; every widget answers 'unchanged'."""

    def __init__(self):
        self.texts = []

    def __getattr__(self, name):
        if name.startswith("ImGui"):
            return 0

        def call(*args):
            if name.startswith("Text"):
                self.texts.append(args[-1])
            if name in ("Checkbox", "SliderFloat", "SliderInt", "Combo", "InputFloat"):
                return False, args[1]
            return False if name.startswith(("Button", "RadioButton", "Is")) else None
        return call


def panel_texts(controller):
    """The texts of one frame of the simulator's panel over ``controller``."""
    from tissuesim.viewer.panel import PanelWidgets

    panel = PanelWidgets()
    panel.__dict__.update(controller=controller, title="", recorder=None, stats=None, frame_seconds=0.0,
                          render_seconds=0.0, sim_time=0.0, show_wireframe=False, show_control=False,
                          show_colours=False, colour_top=1.0, _pending={}, _toggle_recording=lambda: None)
    imgui = TextsImGui()
    panel._panel(imgui)
    return imgui.texts


def test_the_grasper_is_a_mode_whose_force_the_panel_shows_and_s_goes_back_to_it(hybrid):
    c = Controller(hybrid, settings=Settings(method="hybrid"), mode="grasper", scalpel_factory=FakeScalpel)
    assert "t = 0.00 s   grasper 0.000 N" in panel_texts(c)
    top = top_of(c)
    side = np.array([0.0, 1.0, 0.0])
    c.pointer_down(top, top - side, side)
    c.pointer_move(None, top + [0.0, 0.0, 0.008] - side, side)
    for _ in range(5):
        c.advance(c.settings.dt)
    assert c.holding and c.grasper.force[2] < 0.0
    texts = panel_texts(c)
    assert f"t = 0.00 s   grasper {np.linalg.norm(c.grasper.force):.3f} N" in texts
    assert any(text.startswith(f"holding {c.grasper.grasper.held.size} vertices") for text in texts)
    c.pointer_up(hold=True)
    assert any(text.startswith("holding 1 grasper ") for text in panel_texts(c))   # the let-go row
    c.key("s")
    assert c.mode == "scalpel"
    c.key("s")
    assert c.mode == "grasper" and len(c.grasper.held) == 1


def test_the_pin_head_stays_the_papers_mode_and_a_bad_mode_is_refused(hybrid):
    from tissuesim.viewer.panel import MODE_LABELS

    assert Controller(hybrid).mode == "pin" and "paper" in MODE_LABELS["pin"]
    with pytest.raises(SolverError, match="unknown mode 'grasp'"):
        Controller(hybrid, mode="grasp")
