"""``tissuesim view SCENE.toml``: the simulator's controller gets the scene's material, method, supports and gravity;
command-line options the scene sets are refused before anything is built."""

import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.commands.view import SETTINGS_FIELDS, _scene_probe, _scene_scalpel, _scene_settings
from tissuesim.mesh.regions import fixed_region
from tissuesim.scene import parse_scene, solver_options

SCENE = """gravity = [0.0, 0.0, -9.81]
[model]
name = "cube"
resolution = 300
[material]
preset = "muscle"
[method]
name = "pbd"
[method.options]
iterations = 15
damping = 0.2
[support]
fixed = { plane = { point = [0.0, 0.0, 0.07], normal = [0.0, 0.0, -1.0] } }
[[tools]]
kind = "pin-head"
stiffness = 80.0
radius = 0.01
[[tools]]
kind = "probe"
radius = 0.012
[[tools]]
kind = "scalpel"
depth = 0.007
[run]
dt = 0.005
"""


@pytest.fixture(scope="module")
def hybrid():
    from tissuesim.mesh.hybrid import HybridMesh
    from tissuesim.mesh.models import cube

    return HybridMesh.build(cube(300), fine_volume=False)


def test_the_controller_gets_the_scene(tmp_path, hybrid):
    from tissuesim.viewer.controller import Controller

    loaded = parse_scene(SCENE, tmp_path / "scene.toml")
    options = solver_options(loaded, hybrid)
    settings = _scene_settings(loaded, options)
    assert (settings.method, settings.youngs_modulus, settings.poisson_ratio, settings.dt, settings.iterations) == (
        "pbd", 11100.0, 0.45, 0.005, 15)
    assert (settings.stiffness, settings.radius) == (80.0, 0.01)           # the first pin-head's
    extra = {key: value for key, value in options.items() if key not in SETTINGS_FIELDS}
    controller = Controller(hybrid, settings=settings, solver_options=extra, scalpel_factory=_scene_scalpel(loaded))
    _scene_probe(loaded, controller)
    solver = controller.solver
    assert controller.probe.radius == 0.012                                  # the first probe's
    controller.set_mode("scalpel")
    assert controller.scalpel.depth == 0.007                                 # the first scalpel's
    held = fixed_region({"plane": {"point": [0.0, 0.0, 0.07], "normal": [0.0, 0.0, -1.0]}}, hybrid.surface.vertices)
    assert np.array_equal(solver.fixed, held) and solver.rest_positions[solver.fixed, 2].min() >= 0.07
    assert np.allclose(solver.gravity, [0.0, 0.0, -9.81], rtol=0, atol=0)
    assert (solver.density, solver.damping) == (1050.0, 0.2)


def test_an_option_the_scene_sets_is_refused_beside_it(tmp_path, capsys):
    (tmp_path / "scene.toml").write_text(SCENE)
    assert main(["view", str(tmp_path / "scene.toml"), "--method", "fem"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--method is set by the scene file" in err


def test_a_bad_fix_is_refused_before_the_mesh_is_built(capsys):
    assert main(["view", "cube", "--fix", "box:0,0:1,1,1"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--fix 'box:0,0:1,1,1'" in err and "building" not in err


def test_a_scene_holds_its_own_region(tmp_path, capsys):
    (tmp_path / "scene.toml").write_text(SCENE)
    assert main(["view", str(tmp_path / "scene.toml"), "--fix", "bottom:0.2"]) == 1
    assert "--fix is set by the scene file" in capsys.readouterr().err
