"""A scene's scripted tools play in the simulator (tissuesim view scene.toml) until the user takes over."""

from pathlib import Path

import numpy as np

from tissuesim.commands.view import SETTINGS_FIELDS, scene_hybrid
from tissuesim.scene import read_scene, solver_options
from tissuesim.viewer.controller import Controller
from tissuesim.viewer.playback import ScenePlayback
from tissuesim.viewer.settings import Settings

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _controller(name: str) -> Controller:
    loaded = read_scene(EXAMPLES / name)
    hybrid, _ = scene_hybrid(loaded, progress=False)
    options = solver_options(loaded, hybrid)
    extra = {key: value for key, value in options.items() if key not in SETTINGS_FIELDS}
    settings = Settings(method=loaded.scene.method.name, dt=loaded.scene.run.dt,
                        **{key: options[key] for key in SETTINGS_FIELDS if key in options and key != "dt"})
    return Controller(hybrid, settings=settings, solver_options=extra, playback=ScenePlayback(loaded))


def test_the_scripted_probe_presses_as_the_script_says_and_a_press_takes_over():
    c = _controller("probe_block.toml")
    assert c.playback.playing and c.playback.end == 0.3
    for _ in range(20):
        c.advance(c.settings.dt)
    assert c.playback.time > 0.15 and len(c.playback.acting(c.solver.positions)[1]) == 1
    top = c.solver.rest_positions[:, 2].max()
    pressed = top - c.solver.positions[:, 2].min()
    assert pressed > 0.001                                   # the block is pressed in
    assert "playing" in c.playback.status()
    # the user's own press on the tissue: the script lets go and stops
    hit = c.solver.positions[np.argmax(c.solver.positions[:, 0])]
    c.pointer_down(hit, hit + [0.1, 0.0, 0.0], [-1.0, 0.0, 0.0])
    assert not c.playback.playing and c.playback.acting(c.solver.positions) == ([], [], 0.0)
    assert "took over" in c.notice
    assert len(c.solver.loads) == 0                          # the probe's loads went with it (a grab loads none)
    c.pointer_up()
    c.reset()                                                # R: at rest, and the script plays again
    assert c.playback.playing and c.playback.time == 0.0


def test_the_scripted_scalpel_cuts_and_a_new_solver_keeps_playing():
    c = _controller("liver_retraction.toml")
    start = c.solver.node_count
    for _ in range(12):
        c.advance(c.settings.dt)
    c.configure(material="neo-hookean")                      # a new solver: the script's tools are made anew on it
    for _ in range(int(np.ceil(c.playback.end / c.settings.dt)) + 2):
        c.advance(c.settings.dt)
    assert c.solver.node_count > start                       # the scalpel cut
    pins, _, depth = c.playback.acting(c.solver.positions)
    assert pins == [] and depth > 0.0                        # the blade has its depth
    jaws = c.playback.graspers()                             # the grasper, made anew, holds at the path's end
    assert len(jaws) == 1 and np.allclose(jaws[0][0], [0.1128, -0.0046, 0.0378], atol=1e-12) and jaws[0][1] == 0.008
    grasper = c.playback.tools[0].tool
    assert np.linalg.norm(grasper.targets() - c.solver.positions[grasper.held], axis=1).max() <= grasper.tolerance
    status = c.playback.status()
    assert "played to its end" in status and "grasper " in status and " 0.00 N" not in status


def test_a_scene_without_tools_says_so_and_plays_nothing():
    c = _controller("hanging_sphere.toml")
    assert not c.playback.playing and c.playback.status() == "scene: no scripted tools"
    c.advance(c.settings.dt)
    c.reset()
    assert not c.playback.playing
