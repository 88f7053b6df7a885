"""What the simulator draws and says: creases kept sharp, controls where they act, tools only while active, the
first compilation announced, a bundle loaded (not built). The drawing tests need OpenGL and are skipped without."""

import io

import numpy as np
import pytest

from tissuesim import HybridMesh, make_solver
from tissuesim.mesh import models
from tissuesim.viewer.look import CREASE_DEGREES, crease_split
from tissuesim.viewer.panel import iterations_act


def _normals(vertices, triangles):
    p = vertices[triangles]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def test_the_cube_is_split_along_its_edges_and_smooth_within_each_face():
    surface = models.cube(600)
    source, faces = crease_split(surface.vertices, surface.triangles)
    assert np.array_equal(source[faces], surface.triangles)           # the same triangles, over copies
    normal = _normals(surface.vertices, surface.triangles)
    limit = np.cos(np.radians(CREASE_DEGREES))
    for drawn in range(len(source)):                                  # each drawn vertex lies in one face only
        around = normal[np.flatnonzero(np.any(faces == drawn, axis=1))]
        assert np.all(around @ around[0] > limit)
    # the 8 corners have 3 copies, the other edge vertices 2: more drawn vertices than the cube's
    x = surface.vertices
    on_box = np.isclose(x, x.min(axis=0), rtol=0.0, atol=1e-9) | np.isclose(x, x.max(axis=0), rtol=0.0, atol=1e-9)
    corners = np.flatnonzero(np.all(on_box, axis=1))
    assert len(corners) == 8 and all(np.count_nonzero(source == c) == 3 for c in corners)


def test_a_smooth_surface_and_a_cut_lip_are_not_split():
    surface = models.sphere(600)
    source, faces = crease_split(surface.vertices, surface.triangles)
    assert len(source) == surface.vertex_count and np.array_equal(source[faces], surface.triangles)
    # an open strip (a border, as a cut's lip): the border edges have no neighbour and split nothing
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.1]], dtype=float)
    triangles = np.array([[0, 1, 2], [1, 3, 2]])
    source, _ = crease_split(vertices, triangles)
    assert sorted(source) == [0, 1, 2, 3]


def test_the_iterations_act_only_where_the_step_iterates():
    hybrid = HybridMesh.build(models.cube(300), fine_volume=False)
    assert not iterations_act(make_solver("hybrid", hybrid))        # implicit layer: a linear solve per step
    assert not iterations_act(make_solver("embedded", hybrid))
    assert iterations_act(make_solver("hybrid", hybrid, form="pbd"))
    assert iterations_act(make_solver("pbd", hybrid, integrator="xpbd"))


def test_the_first_compilation_is_announced_once_and_a_cached_run_says_nothing():
    import numba

    from tissuesim.compile_notice import announce_compilation

    @numba.njit
    def twice(x):
        return 2 * x

    said = io.StringIO()
    with announce_compilation("tissuesim test", said):
        twice(1.0)
        twice(np.ones(2))
    lines = said.getvalue().splitlines()
    assert len(lines) == 2 and "first run only" in lines[0] and "compiled 2 kernels" in lines[1]
    said = io.StringIO()
    with announce_compilation("tissuesim test", said):
        twice(3.0)                                                   # compiled already: no event, no line
    assert said.getvalue() == ""


def test_view_says_loading_for_a_bundle_and_building_for_a_model(tmp_path, capsys):
    from tissuesim.commands.view import announce_mesh

    bundle = tmp_path / "organ.npz"
    HybridMesh.build(models.cube(300), fine_volume=False).save(bundle)
    announce_mesh(str(bundle))
    announce_mesh("cube")
    said = capsys.readouterr().err.splitlines()
    assert said == [f"loading the hybrid bundle {bundle}", "building the hybrid mesh of cube"]


def test_the_window_draws_tissue_and_the_pin_head_only_while_it_holds():
    from tissuesim.viewer.gl import opengl_available

    if not opengl_available():
        pytest.skip("no OpenGL (install libegl1 libegl-mesa0 libgl1-mesa-dri)")
    from tissuesim.viewer.app import ViewerApp
    from tissuesim.viewer.controller import Controller

    app = ViewerApp(Controller(HybridMesh.build(models.cube(300), fine_volume=False)), headless=True)
    try:
        app.tick()
        assert not app.show_colours and not app.surface.colours      # tissue by default, colours a switch
        c = app.controller
        top = c.solver.positions[np.argmax(c.solver.positions[:, 2])].copy()
        c.pointer_down(top, top + [0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
        app.tick()
        assert "pin-head" in app._shown
        c.pointer_up()
        c.pointer_move(top, top + [0.0, 0.0, 1.0], [0.0, 0.0, -1.0])   # hovering after the release
        app.tick()
        assert "pin-head" not in app._shown and c.cursor is not None
        app.show_colours = True
        app.tick()
        assert app.surface.colours
    finally:
        app.close()


class _RecordingImGui:
    """Stands in for polyscope's ImGui module: records each call's name; widgets answer 'unchanged'."""

    PAIRS = {"Checkbox", "SliderFloat", "SliderInt", "Combo", "InputFloat"}

    def __init__(self):
        self.calls = []

    def __getattr__(self, name):
        if name.startswith("ImGui"):
            return 0
        def call(*args):
            self.calls.append(name)
            if name in self.PAIRS:
                return False, args[1]
            return False if name.startswith(("Button", "RadioButton", "Is")) else None
        return call


def _panel_calls(controller, *, stats=None):
    """The names of the ImGui calls of one frame of the panel over ``controller``."""
    from tissuesim.viewer.panel import PanelWidgets

    panel = PanelWidgets()
    panel.__dict__.update(controller=controller, title="cube", recorder=None, stats=stats, frame_seconds=0.02,
                          render_seconds=0.01, sim_time=1.0, show_wireframe=False, show_control=False,
                          show_colours=False, colour_top=1.0, _pending={}, _toggle_recording=lambda: None)
    imgui = _RecordingImGui()
    panel._panel(imgui)
    return imgui.calls


def test_the_panel_rows_stay_when_a_pin_head_holds_and_the_simulation_falls_behind():
    """The same widgets in the same order whether or not a pin-head is left holding and the simulation is paused or
    behind: only their texts change, so no row moves under the pointer."""
    from types import SimpleNamespace

    from tissuesim.viewer.controller import Controller

    controller = Controller(HybridMesh.build(models.cube(300), fine_volume=False))
    idle = _panel_calls(controller)
    top = controller.solver.positions[np.argmax(controller.solver.positions[:, 2])].copy()
    controller.pointer_down(top, top + [0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
    controller.pointer_up(hold=True)
    controller.toggle_pause()
    busy = _panel_calls(controller, stats=SimpleNamespace(step_seconds=0.02, behind=True, dropped=0.1))
    assert len(controller.held) == 1 and controller.paused
    assert busy == idle


def test_the_jaws_are_a_ring_of_their_reach_and_a_pair_of_jaws_meeting_at_their_position():
    from tissuesim.viewer.tool_layers import RING_SEGMENTS, jaws_geometry

    graspers = np.array([[0.0, 0.0, 0.1, 0.004], [0.05, 0.0, 0.0, 0.002]])
    nodes, edges = jaws_geometry(graspers)
    per = len(nodes) // 2
    for (position, reach), own in zip([(g[:3], g[3]) for g in graspers], [nodes[:per], nodes[per:]]):
        ring = own[:RING_SEGMENTS]
        np.testing.assert_allclose(np.linalg.norm(ring - position, axis=1), reach, rtol=1e-12)
        np.testing.assert_allclose(own[RING_SEGMENTS:RING_SEGMENTS + 2].mean(axis=0), position, atol=1e-15)
    assert edges.min() == 0 and edges.max() == len(nodes) - 1 and len(edges) == 2 * (RING_SEGMENTS + 3)


def test_the_window_draws_and_records_the_graspers_while_they_hold():
    from tissuesim.viewer.gl import opengl_available

    if not opengl_available():
        pytest.skip("no OpenGL (install libegl1 libegl-mesa0 libgl1-mesa-dri)")
    from tissuesim.viewer.app import ViewerApp
    from tissuesim.viewer.controller import Controller

    app = ViewerApp(Controller(HybridMesh.build(models.cube(300), fine_volume=False), mode="grasper"), headless=True)
    try:
        c = app.controller
        top = c.solver.positions[np.argmax(c.solver.positions[:, 2])].copy()
        c.pointer_down(top, top + [0.0, -1.0, 0.0], [0.0, 1.0, 0.0])
        c.pointer_move(None, top + [0.0, -1.0, 0.005], [0.0, 1.0, 0.0])
        app.tick()
        assert app.ps.has_curve_network("your jaws")
        jaws = app.recorded_tools().graspers
        np.testing.assert_allclose(jaws, [[*(top + [0.0, 0.0, 0.005]), c.grasper.radius]], atol=1e-12)
        c.pointer_up()
        app.tick()
        assert not app.ps.has_curve_network("your jaws") and len(app.recorded_tools().graspers) == 0
    finally:
        app.close()
