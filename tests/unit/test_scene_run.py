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


GRASPER = """[model]
name = "cube"
resolution = 200
[[tools]]
kind = "grasper"
radius = 0.012
path = [{ time = 0.0, position = [0.04, 0.0, 0.05] }, { time = 0.05, position = [0.045, 0.0, 0.052] }]
[run]
duration = 0.1
"""


def test_a_scripted_grasper_carries_what_it_holds_to_its_jaws_and_is_recorded(tmp_path, capsys):
    from tissuesim.recording import read_recording
    from tissuesim.scene import Simulation

    (tmp_path / "scene.toml").write_text(GRASPER)
    loaded = read_scene(tmp_path / "scene.toml")
    simulation = Simulation(loaded, scene_hybrid(loaded, progress=False)[0])
    summary = simulation.run()
    grasper = simulation.tools[0].tool
    held = simulation.solver.positions[grasper.held]
    assert len(grasper.held) >= 2
    assert np.linalg.norm(held - (simulation.solver.rest_positions[grasper.held] + [0.005, 0.0, 0.002]),
                          axis=1).max() <= grasper.tolerance                 # carried rigidly by the jaws' travel
    assert summary.forces["grasper 0"][0] > 0.0                               # it pulls the tissue outward
    assert np.allclose(summary.forces["grasper 0"], -grasper.force, atol=0)

    assert main(["run", str(tmp_path / "scene.toml"), "--quiet", "--record", str(tmp_path / "g.pvd")]) == 0
    last = read_recording(tmp_path / "g.pvd")[-1]
    assert np.allclose(last.tools.graspers, [[0.045, 0.0, 0.052, 0.012]], atol=1e-12)
    assert "grasper 0: force" in capsys.readouterr().out


def test_a_grasp_beyond_the_surface_stops_the_run_in_one_line_and_writes_nothing(tmp_path, capsys):
    (tmp_path / "scene.toml").write_text(GRASPER.replace("[0.04, 0.0, 0.05]", "[0.07, 0.0, 0.05]"))
    assert main(["run", str(tmp_path / "scene.toml"), "--quiet", "--record", str(tmp_path / "g.pvd")]) == 1
    last = capsys.readouterr().err.splitlines()[-1]          # after the progress lines, the error in one line
    assert last.startswith("tissuesim run: error: grasper 0 at t = 0 s, position [0.07, 0.0, 0.05] m: nothing to "
                           "grasp: the nearest surface vertex")
    assert not (tmp_path / "g.pvd").exists() and not (tmp_path / "g_frames").exists()
