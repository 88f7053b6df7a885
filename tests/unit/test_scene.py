"""Scene files: defaults, every refusal naming its key and the fix, the options a scene gives a solver, and the
scripted tool paths."""

import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.fem.presets import preset
from tissuesim.scene import SceneError, material_options, parse_scene
from tissuesim.scene.build import check_method
from tissuesim.scene.script import ScriptedTool

MINIMAL = '[model]\nname = "cube"\n'


def _scene(text, tmp_path):
    return parse_scene(text, tmp_path / "scene.toml")


def _refusal(text, tmp_path) -> str:
    with pytest.raises(SceneError) as caught:
        loaded = _scene(text, tmp_path)
        check_method(loaded)
        material_options(loaded)
    return str(caught.value)


def test_a_minimal_scene_takes_the_papers_defaults(tmp_path):
    loaded = _scene(MINIMAL, tmp_path)
    scene = loaded.scene
    assert scene.method.name == "hybrid" and scene.gravity is None and scene.tools == []
    assert scene.support.fixed.spec() == {"bottom": 0.1} and scene.support.attachments == []
    assert (scene.run.duration, scene.run.dt, scene.run.steps) == (1.0, 0.01, 100)
    assert material_options(loaded) == {"youngs_modulus": 5500.0, "poisson_ratio": 0.3, "density": 1000.0,
                                        "material": "linear"}


def test_a_preset_gives_its_values_and_a_key_overrides_one(tmp_path):
    loaded = _scene(MINIMAL + '[material]\npreset = "kidney"\nyoungs_modulus = 8000.0\nmodel = "corotated"\n',
                    tmp_path)
    options = material_options(loaded)
    assert options == {"youngs_modulus": 8000.0, "poisson_ratio": preset("kidney").poisson_ratio,
                       "density": preset("kidney").density, "material": "corotated"}


@pytest.mark.parametrize("text, expected", [
    (MINIMAL + "[material]\nstiffnes = 3\n", "material.stiffnes: unknown key; the keys accepted here are preset, "
                                             "youngs_modulus, poisson_ratio, density, model"),
    (MINIMAL + "colour = 1\n", "model.colour: unknown key"),
    ('[model]\nname = "cube"\n[[tools]]\nkind = "pin-head"\nstiffnes = 3\n', "tools[0].stiffnes: unknown key; "
                                                                            "the keys accepted here are name, path, "
                                                                            "kind, stiffness, radius"),
    ('[model]\nname = "livr"\n', "model.name: unknown built-in model 'livr'; choose one of cube, sphere"),
    ('[model]\nname = "cube"\nfile = "a.obj"\n', "model: give exactly one of name"),
    ('[model]\nfile = "missing.obj"\n', "model.file: no file"),
    (MINIMAL + '[material]\npoisson_ratio = "0.3"\n', "material.poisson_ratio: input should be a valid number; give "
                                                      "Poisson's ratio"),
    (MINIMAL + "[material]\npoisson_ratio = 0.5\n", "poisson_ratio must lie in (-1, 0.49]"),
    (MINIMAL + '[material]\npreset = "spleen"\n', "material.preset: unknown preset 'spleen'; choose one of liver"),
    (MINIMAL + "[run]\nduration = -1.0\n", "run.duration: input should be greater than 0"),
    (MINIMAL + "[run]\nduration = 0.1\ndt = 0.2\n", "run.dt: 0.2 s is longer than the duration"),
    (MINIMAL + '[[tools]]\nkind = "probe"\n', "tools[0].radius: missing; add it: the sphere's (capsule's) radius [m]"),
    (MINIMAL + '[[tools]]\nkind = "knife"\n', "tools[0]: a tool needs kind = one of 'pin-head', 'probe', 'scalpel'"),
    (MINIMAL + '[[tools]]\nkind = "scalpel"\npath = [{time = 0.0, position = [0, 0, 0.08]}, '
               '{time = 0.1, position = [0, 0, 0.08]}, {time = 0.3, position = [0, 0, 0.08]}, '
               '{time = 0.2, position = [0, 0, 0.08]}]\n',
     "tools[0].path[3].time: 0.2 s is not after path[2].time 0.3 s; keyframe times must increase"),
    (MINIMAL + '[[tools]]\nkind = "scalpel"\npath = [{time = 0.0, position = [0, 0]}]\n',
     "tools[0].path[0].position: list should have at least 3 items"),
    (MINIMAL + '[[tools]]\nkind = "scalpel"\npath = [{time = 2.0, position = [0, 0, 0]}]\n',
     "tools[0].path[0].time: 2 s is after the run's end (run.duration = 1 s)"),
    (MINIMAL + "[support]\nfixed = { bottom = 0.1, indices = [1] }\n", "support.fixed: a region takes exactly one of"),
    (MINIMAL + "[support]\nfixed = { bottom = 1.5 }\n", "support.fixed.bottom: input should be less than 1"),
    (MINIMAL + '[method]\nname = "fast"\n', "method.name: unknown method 'fast'; choose one of hybrid"),
    (MINIMAL + "[method.options]\nfixed = [1, 2]\n", "method.options.fixed: the scene sets fixed in [support] fixed"),
    (MINIMAL + "[method.options]\nspeed = 2\n", "method.options.speed: the hybrid method has no option 'speed'; its "
                                                "options are"),
    ("[model\nname = 1\n", "scene.toml is not valid TOML"),
    (MINIMAL + '[[tools]]\nkind = "grasper"\n', "tools[0].radius: missing; add it: the jaws' reach [m]"),
    (MINIMAL + '[[tools]]\nkind = "grasper"\nradius = 0.0\n', "tools[0].radius: input should be greater than 0"),
    (MINIMAL + '[[tools]]\nkind = "grasper"\nradius = 0.004\nstiffness = 50.0\n',
     "tools[0].stiffness: unknown key; the keys accepted here are name, path, kind, radius, tolerance"),
    (MINIMAL + '[[tools]]\nkind = "grasper"\nradius = 0.004\npath = [{time = 0.0, position = [0, 0, 0.08], '
               'rotation = [0.0, 0.1]}]\n', "tools[0].path[0].rotation: list should have at least 3 items after "
                                           "validation, not 2; give the jaws' orientation, a rotation vector"),
    (MINIMAL + '[[tools]]\nkind = "grasper"\nradius = 0.004\npath = [{time = 0.0, position = [0, 0, 0.08], '
               'closed = false}]\n', "tools[0].path[0].closed: unknown key; the keys accepted here are time, "
                                      "position, pressed, rotation"),
    (MINIMAL + '[[tools]]\nkind = "grasper"\nradius = 0.004\npath = [{time = 0.2, position = [0, 0, 0.08]}, '
               '{time = 0.1, position = [0, 0, 0.09]}]\n', "tools[0].path[1].time: 0.1 s is not after path[0].time"),
    (MINIMAL + '[[tools]]\nkind = "probe"\nradius = 0.01\npath = [{time = 0.0, position = [0, 0, 0.08], '
               'rotation = [0.0, 0.0, 0.1]}]\n', "tools[0].path[0].rotation: unknown key; the keys accepted here "
                                                 "are time, position, pressed"),
])
def test_a_bad_scene_is_refused_naming_the_key_and_the_fix(tmp_path, text, expected):
    assert expected in _refusal(text, tmp_path)


def test_every_defect_is_listed_at_once(tmp_path):
    message = _refusal('[model]\nname = "livr"\n[run]\ndt = -1.0\nsteps = 3\n', tmp_path)
    assert message.startswith("scene.toml: 3 problems: ")
    assert "model.name" in message and "run.dt" in message and "run.steps" in message


def test_the_command_prints_one_line_and_exits_1(tmp_path, capsys):
    (tmp_path / "bad.toml").write_text('[model]\nname = "cube"\n[[tools]]\nkind = "probe"\n')
    assert main(["run", str(tmp_path / "bad.toml")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("tissuesim run: error: bad.toml: 1 problem: tools[0].radius")


def test_a_refused_scene_leaves_an_old_recording_alone(tmp_path):
    (tmp_path / "bad.toml").write_text('[model]\nname = "cube"\n[run]\ndt = 0.0\n')
    (tmp_path / "old.pvd").write_text("old")
    assert main(["run", str(tmp_path / "bad.toml"), "--record", str(tmp_path / "old.pvd")]) == 1
    assert (tmp_path / "old.pvd").read_text() == "old"


class _Recorder:
    """A tool that records what it is asked (grab, drag, release)."""

    def __init__(self):
        self.calls = []

    def __getattr__(self, name):
        return lambda *args: self.calls.append((name, *[np.round(a, 6).tolist() for a in args]))


def _scripted(tmp_path, path_text):
    loaded = _scene(MINIMAL + f'[[tools]]\nkind = "pin-head"\npath = [{path_text}]\n', tmp_path)
    return ScriptedTool(loaded.scene.tools[0], _Recorder(), name="pin")


def test_a_path_interpolates_between_keyframes_and_holds_after_the_last(tmp_path):
    tool = _scripted(tmp_path, "{time = 0.1, position = [0, 0, 0]}, {time = 0.3, position = [0.02, 0, 0]}")
    assert tool.target(0.05) == (False, None)                       # not in play before its first keyframe
    pressed, where = tool.target(0.15)
    assert pressed and np.allclose(where, [0.005, 0.0, 0.0], atol=1e-15)
    assert np.allclose(tool.target(0.5)[1], [0.02, 0.0, 0.0], atol=0)


def test_a_pin_head_grabs_drags_and_lets_go_as_its_path_says(tmp_path):
    tool = _scripted(tmp_path, "{time = 0.0, position = [0, 0, 0]}, {time = 0.2, position = [0.02, 0, 0]}, "
                               "{time = 0.3, position = [0.02, 0, 0], pressed = false}")
    for time in (0.0, 0.1, 0.2, 0.3, 0.4):
        tool.update(time)
    assert tool.tool.calls == [("grab", [0.0, 0.0, 0.0]), ("drag", [0.0, 0.0, 0.0]), ("drag", [0.01, 0.0, 0.0]),
                               ("drag", [0.02, 0.0, 0.0]), ("release",)]
    assert not tool.pressed and tool.force is None


def test_a_capsule_probe_carries_its_shaft_along_its_path(tmp_path):
    loaded = _scene(MINIMAL + '[[tools]]\nkind = "probe"\nradius = 0.005\nshaft = [0.0, 0.0, 0.05]\n'
                              'path = [{time = 0.0, position = [0, 0, 0.09]}, {time = 0.1, position = [0.01, 0, 0.09]},'
                              ' {time = 0.2, position = [0.01, 0, 0.09], pressed = false}]\n', tmp_path)
    tool = ScriptedTool(loaded.scene.tools[0], _Recorder(), name="probe")
    for time in (0.0, 0.05, 0.2):
        tool.update(time)
    assert tool.tool.calls == [("settle", [0.0, 0.0, 0.09], [0.0, 0.0, 0.14]),        # its contact solved there
                               ("settle", [0.005, 0.0, 0.09], [0.005, 0.0, 0.14]), ("release",)]


def test_a_grasper_grabs_carries_turns_and_lets_go_as_its_path_says(tmp_path):
    loaded = _scene(MINIMAL + '[[tools]]\nkind = "grasper"\nradius = 0.004\npath = ['
                              '{time = 0.0, position = [0, 0, 0.08], rotation = [0.0, 0.0, 0.2]}, '
                              '{time = 0.2, position = [0.02, 0, 0.08], rotation = [0.0, 0.0, 0.6]}, '
                              '{time = 0.3, position = [0.02, 0, 0.08], pressed = false}]\n', tmp_path)
    tool = ScriptedTool(loaded.scene.tools[0], _Recorder(), name="grasper")
    for time in (0.0, 0.1, 0.3):
        tool.update(time)
    names = [call[0] for call in tool.tool.calls]
    assert names == ["grab", "move_to", "move_to", "release"]
    assert tool.tool.calls[0][1] == [0.0, 0.0, 0.08] and tool.tool.calls[2][1] == [0.01, 0.0, 0.08]
    turn = np.array(tool.tool.calls[2][2])                          # about the jaws since the grab: 0.2 rad about z
    assert np.allclose(turn, [[np.cos(0.2), -np.sin(0.2), 0.0], [np.sin(0.2), np.cos(0.2), 0.0], [0.0, 0.0, 1.0]],
                       atol=1e-6)
    assert np.allclose(tool.tool.calls[1][2], np.eye(3), atol=0)    # at the grab: unturned
    # a keyframe without a rotation keeps the one before
    assert np.allclose(tool.orientation(0.3).as_rotvec(), [0.0, 0.0, 0.6], atol=1e-12)
    assert not tool.pressed and tool.force is None
