"""The examples double as regression tests: each runs as a user would run it."""

import importlib.util
import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _example(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# each script as a user runs it, at its defaults (in a scratch folder: what it writes goes there), the haptic
# loop's visual loop cut from 1 s to 0.2 s
SCRIPTS = {"pinhead_drag": [], "grasp_lift": [], "scalpel_cut": [], "probe_press": [], "two_tools": [],
           "scene_file": [], "haptic_loop": ["--seconds", "0.2"], "scripted_session": []}


def test_every_example_script_is_run_here():
    assert set(SCRIPTS) == {path.stem for path in EXAMPLES.glob("*.py")}


@pytest.mark.parametrize("name", sorted(SCRIPTS))
def test_the_script_runs_and_reports(name, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [f"{name}.py", *SCRIPTS[name]])
    runpy.run_path(str(EXAMPLES / f"{name}.py"), run_name="__main__")
    assert capsys.readouterr().out.strip()           # it says what happened


def test_the_grasp_lift_carries_the_held_patch_and_its_pull_grows_linearly():
    result = _example("grasp_lift").lift(np.array([0.002, 0.004]), resolution=400)
    assert np.all(result["miss"] <= result["tolerance"])            # the held patch is where the jaws are
    # the linear hybrid: twice the lift, twice the pull (to the iteration's tolerance)
    assert np.linalg.norm(result["pull"][1] - 2 * result["pull"][0]) <= 1e-3 * np.linalg.norm(result["pull"][1])
    assert result["pull"][0, 2] > 0.0


def test_pinhead_drag_lifts_the_grabbed_node_and_release_returns_it():
    result = _example("pinhead_drag").drag_liver(frames=40, lift=0.01, stiffness=50.0, resolution=400)
    assert result["force_N"] == pytest.approx(50.0 * 0.01)                # eq 24 at the full cursor travel
    assert 0.002 < result["held_lift_m"] < 0.01                             # up, but less than the cursor went
    assert abs(result["released_lift_m"]) < 1e-5                            # back to rest once released


def test_scripted_session_records_the_drag_and_the_cut(tmp_path):
    from tissuesim.recording import read_recording

    result = _example("scripted_session").run_session(tmp_path / "s.pvd", frames=20, pull=0.02, resolution=400)
    assert result["force_N"] == pytest.approx(50.0 * 0.02)                 # eq 24 at the full cursor travel
    assert 0.002 < result["held_motion_m"] < 0.02                           # followed, less than the cursor
    frames = read_recording(tmp_path / "s.pvd")
    # every drag frame, the frames that moved after the release, and each cutting move that cut something (a move
    # that ends within the snap distance of the last tip cuts nothing until the blade goes on): 38 of 50 here
    assert len(frames) == result["frames"] >= 30
    assert np.count_nonzero(np.any(frames[5].force, axis=1)) == 1 and not np.any(frames[-1].force)  # held, released
    assert result["scalpel"]                                                # the library has one: the cut ran
    assert len(frames[-1].cut_edges) == result["cut_edges"] > 0
    grown = len(frames[-1].positions) - len(frames[0].positions)
    assert grown == result["vertices_added"] > 0


def test_the_cut_adds_vertices_keeps_one_piece_and_opens_linearly_under_a_pull():
    cut = _example("scalpel_cut")
    gaps = []
    for pull in (0.001, 0.002):
        solver, result = cut.cut_liver(resolution=400)
        assert result["vertices_added"] == result["grown_by"] > 0          # the reports add up to the new vertices
        assert result["cut_edges"] > 0 and result["pieces"] == 1            # a wound, and no piece cut loose
        assert len(cut.lip_pairs(solver)) > 0
        wound = cut.open_wound(solver, pull=pull)
        # rest data come from the rest triangles: the unloaded cut body rests where it was, its lips closed
        assert wound["rest_motion_m"] < 1e-12 and wound["gap_unloaded_m"] < 1e-12
        gaps.append(wound["gap_pulled_m"])
    assert gaps[0] > 1e-4                                                   # a pull across the cut opens it
    assert gaps[1] == pytest.approx(2.0 * gaps[0], rel=1e-6)                 # linear model: twice the pull, twice


def test_the_probe_is_pushed_up_harder_the_deeper_it_goes_and_the_stiffer_the_block():
    probe = _example("probe_press")
    depths = np.array([0.001, 0.002, 0.004])
    result = probe.press(depths)
    force = result["force_N"]
    assert np.all(force[:, 2] > 0)                                          # the tissue pushes the probe up
    assert np.all(np.linalg.norm(force[:, :2], axis=1) < 0.05 * force[:, 2])  # frictionless, on a flat face
    ratios = force[1:, 2] / force[:-1, 2]                                   # each depth twice the last
    # between a flat punch's proportional force (2) and Hertz's d^1.5 (2.83), 5 % either side
    assert np.all((ratios > 0.95 * 2.0) & (ratios < 1.05 * 2.0 ** 1.5))
    # displacement-driven: the top under the probe goes down as deep as the probe was put, to 5 %
    assert result["top_displacement_m"][:, 2] == pytest.approx(-depths, rel=0.05)
    assert result["smallest_gap_m"] >= -result["tolerance_m"]             # no vertex inside the probe
    # displacement-driven in a linear model: twice as stiff a block pushes back twice as hard at the same depths
    # (to the contact tolerance, 1e-3 of the probe's radius)
    stiffer = probe.press(depths, youngs_modulus=2 * 5500.0)
    assert stiffer["force_N"][:, 2] == pytest.approx(2.0 * force[:, 2], rel=1e-3)
    assert stiffer["top_displacement_m"] == pytest.approx(result["top_displacement_m"], rel=1e-3, abs=1e-7)
    slid = probe.slide(depth=0.004, travel=0.02, frames=10)
    # frictionless and elastic: the slide ends where a press straight down there does, to 2 %
    assert slid["slid_force_N"][2] == pytest.approx(slid["pressed_force_N"][2], rel=0.02)


def test_two_pinheads_act_together_and_their_answers_superpose():
    tools = _example("two_tools")
    pull_a, pull_b = np.array([0.0, 0.0, 0.004]), np.array([0.003, 0.0, 0.002])
    result = tools.two_pinheads(pull_a, pull_b)
    assert result["force_a_N"] == pytest.approx(50.0 * pull_a, abs=1e-12)    # eq 24: k × the cursor's travel
    assert result["force_b_N"] == pytest.approx(50.0 * pull_b, abs=1e-12)
    node_a, node_b = result["nodes"]
    assert node_a != node_b
    both, alone_a, alone_b = result["both_m"], result["a_m"], result["b_m"]
    assert alone_a[node_a, 2] > 0 and alone_b[node_b, 0] > 0               # each moves its node its own way
    # a linear model: the answer under both is the sum of the answers under each, to round-off
    assert np.abs(both - alone_a - alone_b).max() < 1e-9 * np.abs(both).max()


def test_a_pinhead_held_while_cutting_keeps_pulling():
    result = _example("two_tools").hold_and_cut(pull=0.01, resolution=400)
    assert result["vertices_added"] > 0
    assert result["loads"] == 1                                            # the pin-head's load outlived the cut
    assert result["force_N"] == pytest.approx([0.5, 0.0, 0.0], abs=1e-12)    # eq 24: 50 N/m × 10 mm
    assert result["node_force_N"] == pytest.approx(result["force_N"], abs=1e-12)  # still on the node it grabbed
    assert result["held_displacement_m"][0] > 0.001                        # which rests moved along the pull


def test_a_scene_file_runs_to_the_static_press_and_records(tmp_path):
    from tissuesim.recording import read_recording
    from tissuesim.scene import Simulation

    scene = _example("scene_file")
    simulation, summary = scene.run_scene(EXAMPLES / "probe_block.toml", record=tmp_path / "probe.pvd")
    assert summary.steps == 50 and summary.simulated == pytest.approx(0.5, rel=1e-12)
    force = summary.forces["probe"]                                        # on the tissue
    assert force[2] < 0 and np.linalg.norm(force[:2]) < 0.05 * -force[2]  # pushed straight down
    # the scripted press, held for 0.2 s, ends at the static equilibrium with the probe there, to 2 %
    fresh = Simulation(simulation.scene_file, simulation.solver.hybrid)
    probe = simulation.tools[0].tool
    static = type(probe)(fresh.solver, radius=probe.radius)
    static.press_static(probe.center)
    assert -force[2] == pytest.approx(static.force[2], rel=0.02)
    frames = read_recording(tmp_path / "probe.pvd")
    assert frames[0].time == 0.0 and frames[-1].time == pytest.approx(0.5)
    largest = np.linalg.norm(frames[-1].displacement, axis=1).max()
    assert largest == pytest.approx(summary.final_displacement, rel=1e-6)    # the last frame is the end state


def test_the_haptic_hand_settles_where_the_full_solver_puts_the_node():
    haptic = _example("haptic_loop")
    solver = haptic.liver_solver(400)
    held = haptic.hold(solver, lift=0.01)
    assert np.array_equal(held["first_N"], np.zeros(3))                   # grabbing alone applies no force
    assert held["speed"] < 1e-8                                            # settled: what follows is equilibrium
    force = held["force_N"]
    assert force[2] > 0 and np.array_equal(held["felt_N"], -force)         # it pulls up; the hand feels −f
    # the full solver loaded with that force puts the node where the coupling holds it (a linear model: exactly)
    full = haptic.liver_solver(400).solve_static(held["node"], force, radius=haptic.TIP)[held["node"]]
    moved = np.linalg.norm(held["coupled_m"] - solver.rest_positions[held["node"]])
    assert moved > 1e-3 and np.linalg.norm(full - held["coupled_m"]) < 1e-6 * moved


def test_the_haptic_servo_thread_ticks_beside_a_visual_loop():
    haptic = _example("haptic_loop")
    run = haptic.visual_loop(haptic.liver_solver(400), seconds=0.3)
    assert run["frames"] > 0 and run["statistics"].ticks > 0              # both loops ran (never their timing)
    assert run["displacement_m"][2] > 0                                    # the hand's pull lifted the node
