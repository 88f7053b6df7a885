"""A scene naming a surface file: the file is found relative to the scene, scaled to metres, and run."""

import numpy as np

from tissuesim.cli import main
from tissuesim.commands.view import scene_hybrid
from tissuesim.io import write_surface
from tissuesim.mesh.models import cube
from tissuesim.mesh.surface import SurfaceMesh
from tissuesim.scene import read_scene

SCENE = """[model]
file = "meshes/block.obj"
scale = 0.01                 # the file is in centimetres
[[tools]]
kind = "pin-head"
path = [{ time = 0.0, position = [0.04, 0.0, 0.06] }, { time = 0.05, position = [0.05, 0.0, 0.06] }]
[run]
duration = 0.1
"""


def _scene(tmp_path):
    surface = cube(200)
    (tmp_path / "meshes").mkdir()
    write_surface(tmp_path / "meshes" / "block.obj", SurfaceMesh(100.0 * surface.vertices, surface.triangles))
    (tmp_path / "scene.toml").write_text(SCENE)
    return tmp_path / "scene.toml"


def test_a_surface_file_is_read_beside_the_scene_and_scaled(tmp_path, monkeypatch):
    path = _scene(tmp_path)
    monkeypatch.chdir(tmp_path / "meshes")           # the scene's folder counts, not the current one
    hybrid, _ = scene_hybrid(read_scene(path), progress=False)
    assert np.allclose(np.ptp(hybrid.surface.vertices, axis=0), [0.08, 0.08, 0.08], rtol=1e-9, atol=0)


def test_the_run_pulls_with_the_pin_heads_force(tmp_path, capsys):
    assert main(["run", str(_scene(tmp_path)), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "10 steps, 0.1 s simulated" in out and "pin-head 0: force 0.5 N, [0.5, 0.0, 0.0] N" in out


def test_the_default_support_is_the_solvers_own_bottom(tmp_path):
    from tissuesim.mesh.regions import bottom_nodes
    from tissuesim.scene import make_scene_solver, solver_options

    loaded = read_scene(_scene(tmp_path))
    hybrid, _ = scene_hybrid(loaded, progress=False)
    assert "fixed" not in solver_options(loaded, hybrid)     # as --fix's default: the volume's bottom is held too
    solver = make_scene_solver(loaded, hybrid)
    assert np.array_equal(solver.fixed, bottom_nodes(hybrid.surface.vertices))
