"""Offscreen drawing (polyscope on EGL): real pixels of the figures, the window layer headless, the render command.

These need OpenGL (Mesa's EGL on a machine without GPU; the Makefile installs it) and are skipped where there is
none at all.
"""

import numpy as np
import pytest

from tissuesim import HybridMesh, make_solver
from tissuesim.cli import main
from tissuesim.experiments.protocol import load_node
from tissuesim.mesh import models
from tissuesim.viewer.gl import opengl_available

pytestmark = pytest.mark.skipif(not opengl_available(), reason="no OpenGL (install libegl1 libegl-mesa0 "
                                                               "libgl1-mesa-dri)")


@pytest.fixture(scope="module")
def hybrid():
    return HybridMesh.build(models.liver(400))


def test_the_deformed_image_differs_from_the_rest_image_near_the_load_only(hybrid):
    from tissuesim.viewer.figures import render_panels

    rest, triangles = hybrid.surface.vertices, hybrid.surface.triangles
    node = load_node(rest, triangles)
    pulled = make_solver("hybrid", hybrid).solve_static(node, [0.0, 0.0, 5.0])
    images, vmax = render_panels(rest, triangles, [rest, pulled, pulled], markers=[None, None, node])
    assert vmax > 10.0  # mm: the colour bar spans the largest displacement
    marker = np.argwhere(np.any(images[2] != images[1], axis=2)).mean(axis=0)  # where the pin-head is drawn
    changed = np.any(np.abs(images[1].astype(int) - images[0]) > 30, axis=2)
    row, col = marker.astype(int)
    near = changed[max(row - 40, 0): row + 40, max(col - 40, 0): col + 40].mean()
    bottom = changed[-60:].mean()  # the fixed bottom of the model, far from the load
    # the square around the pin-head holds the pulled spike (changed) and background above it (unchanged)
    assert near > 0.1 and bottom < 0.25 * near


def test_the_window_layer_runs_headless_and_records(hybrid, tmp_path):
    from tissuesim.recording import read_recording
    from tissuesim.viewer.app import ViewerApp
    from tissuesim.viewer.replay import ReplayApp
    from tissuesim.viewer.controller import Controller

    controller = Controller(hybrid)
    app = ViewerApp(controller, headless=True, record=tmp_path / "s.pvd")
    top = controller.solver.positions[load_node(hybrid.surface.vertices, hybrid.surface.triangles)].copy()
    controller.pointer_down(top, top + [0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
    app.show_wireframe = app.show_control = True
    for i in range(4):
        controller.pointer_move(None, top + [0.0, 0.0, 1.0 + 0.005 * i], [0.0, 0.0, -1.0])
        app.tick()  # polyscope calls app.frame, then draws
    app.close()
    frames = read_recording(tmp_path / "s.pvd")
    assert len(frames) >= 1 and frames[-1].force[controller.pin.node, 2] > 0.0
    replay = ReplayApp(frames, headless=True)
    replay.ps.set_user_callback(replay.frame)
    replay.ps.frame_tick()
    replay.close()
    assert replay.index == 1 % len(frames)


def test_render_command_writes_the_figure_and_links_it_from_the_report(tmp_path, capsys):
    report = tmp_path / "report.md"
    report.write_text("# Report\n\ntext\n")
    assert main(["render", "cube", "--resolution", "300", "--output", str(tmp_path), "--report", str(report)]) == 0
    assert (tmp_path / "deformation_cube.png").stat().st_size > 10_000
    text = report.read_text()
    assert text.startswith("# Report") and "![deformation_cube](deformation_cube.png)" in text
    main(["render", "cube", "--resolution", "300", "--output", str(tmp_path), "--report", str(report)])
    assert report.read_text().count("## Figures") == 1  # the section is replaced, not repeated


def test_the_incision_image_shows_the_gap(tmp_path):
    from tissuesim.experiments.wound import open_wound, scripted_incision
    from tissuesim.viewer.figures import OPENING_FORCE, incision_figure, render_panels

    hybrid = HybridMesh.build(models.cube(600), fine_volume=False)
    solver = make_solver("hybrid", hybrid)
    line = scripted_incision(solver)["line"]
    closed = solver.positions.copy()
    node = open_wound(solver, line, force=OPENING_FORCE)["node"]
    middle = 0.5 * (line[0] + line[1])
    focus = middle + np.array([[-0.01, -0.01, -0.005], [0.01, 0.01, 0.002]])  # the wound's middle, close up
    images, _ = render_panels(solver.rest_positions, solver.hybrid.surface.triangles, [closed, solver.positions],
                              focus=focus, elevation=55.0)
    h, w = images[0].shape[:2]
    centre = (slice(h // 3, 2 * h // 3), slice(w // 3, 2 * w // 3))
    darker = images[1][centre].astype(int).sum(axis=2) < images[0][centre].astype(int).sum(axis=2) - 60
    assert darker.mean() > 0.05  # the open wound shows its dark inside where the closed cut showed skin
    assert incision_figure(hybrid, "cube", tmp_path / "incision_cube.png").stat().st_size > 10_000
    assert node >= 0
