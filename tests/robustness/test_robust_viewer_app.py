"""The window layer headless (polyscope on EGL): the panel's record / stop recording leave the window working.

Skipped where there is no OpenGL at all (as tests/unit/test_viewer_render.py).
"""

import time
from contextlib import contextmanager

import numpy as np
import pytest

from tissuesim.recording import read_recording
from tissuesim.viewer.gl import opengl_available

pytestmark = pytest.mark.skipif(not opengl_available(), reason="no OpenGL (install libegl1 libegl-mesa0 "
                                                               "libgl1-mesa-dri)")
DOWN = np.array([0.0, 0.0, -1.0])


@contextmanager
def grabbing_app(cube, record):
    """A headless window over ``cube`` recording to ``record``, its pin-head holding the top node: yields
    ``(app, top)`` and closes the window on the way out."""
    from tissuesim.viewer.app import ViewerApp
    from tissuesim.viewer.controller import Controller

    app = ViewerApp(Controller(cube), headless=True, record=record)
    try:
        top = app.controller.solver.positions[np.argmax(app.controller.solver.positions[:, 2])].copy()
        app.controller.pointer_down(top, top + [0.0, 0.0, 1.0], DOWN)
        yield app, top
    finally:
        app.close()


def drag(app, top, frames):
    """Hold the pin-head on ``top`` and pull it up 1 mm per frame, one window frame each."""
    for i in range(frames):
        app.controller.pointer_move(None, top + [0.0, 0.0, 1.0 + 0.001 * (i + 1)], DOWN)
        app.tick()


def test_stop_recording_keeps_the_window_and_the_next_recording_gets_its_own_name(small_cube, tmp_path):
    from tissuesim.viewer.app import SURFACE

    with grabbing_app(small_cube, tmp_path / "first.pvd") as (app, top):
        drag(app, top, 3)
        app._toggle_recording()  # the panel's "stop recording"
        assert app.controller.notice == f"recorded to {tmp_path / 'first.pvd'}" and app.recorder is None
        assert app.ps.has_surface_mesh(SURFACE) and app.mesh is not None  # the window still shows the model
        drag(app, top, 2)  # the frame callback runs on
        app._toggle_recording()  # the panel's "record" again
        second, started = app.record_path, app.sim_time
        assert second != tmp_path / "first.pvd" and second.parent == tmp_path
        drag(app, top, 3)
    first = read_recording(tmp_path / "first.pvd")
    assert len(first) >= 1 and first[-1].time <= started  # how many frames stepped depends on the wall clock
    assert read_recording(second)[0].time == started  # the new one begins with the frame it was started on


def test_a_frame_that_cannot_be_written_ends_the_recording_and_the_session_goes_on(small_cube, tmp_path):
    import shutil

    from tissuesim.viewer.app import SURFACE

    with grabbing_app(small_cube, tmp_path / "s.pvd") as (app, _):
        shutil.rmtree(app.recorder._partial)  # where its frames go vanishes, as a full disk fails a write
        app._last = time.perf_counter() - 0.05  # 50 ms since the last frame: this frame steps, whatever the clock
        app.tick()
        assert app.recorder is None
        assert app.controller.notice.startswith("recording stopped and discarded: cannot write")
        assert app.ps.has_surface_mesh(SURFACE)
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # nothing half-written is left


@pytest.mark.parametrize("signal_name, code", [("interrupt", 130), ("terminate", 143)])
def test_an_interrupted_view_keeps_its_recording_and_says_where(small_cube, tmp_path, monkeypatch, capsys,
                                                                 signal_name, code):
    """Ctrl-C or SIGTERM ends the window: the session is the user's, so its recording replaces the old one of that
    name (unlike a ``with Recorder(...)`` block) and the command names it."""
    from tissuesim import cli
    from tissuesim.recording import Frame, Recorder, border_edges
    from tissuesim.viewer import app as app_module
    from tissuesim.viewer import gl

    real = gl.polyscope  # one polyscope context per process: the tests' is headless

    def headless_polyscope(*, headless):
        return real(headless=True)

    monkeypatch.setattr(gl, "polyscope", headless_polyscope)
    monkeypatch.setattr(app_module, "polyscope", headless_polyscope)

    def interrupted_window(ps, frame, close):  # two frames, then the signal arrives (as show_window does it)
        ps.set_user_callback(frame)
        try:
            ps.frame_tick()
            ps.frame_tick()
            raise KeyboardInterrupt if signal_name == "interrupt" else cli.Terminated()
        finally:
            close()

    monkeypatch.setattr(app_module, "show_window", interrupted_window)
    monkeypatch.setattr("tissuesim.commands.view.load_hybrid", lambda *args, **kwargs: (small_cube, "cube"))
    old = tmp_path / "old.pvd"
    with Recorder(old) as recorder:  # an old recording of a tetrahedron
        points = np.eye(4, 3) * 0.01
        triangles = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int32)
        recorder.add(Frame(0.0, points, triangles, np.zeros((4, 3)), np.zeros((4, 3)), border_edges(triangles)))
    assert cli.main(["view", "cube", "--record", str(old)]) == code
    assert f"recorded {old}" in capsys.readouterr().err
    assert len(read_recording(old)[0].positions) == small_cube.surface.vertex_count  # the session's, not the old
