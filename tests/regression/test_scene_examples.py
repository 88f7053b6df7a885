"""The example scenes run as a user runs them, and answer as an elastic body does: a probe presses as deep as it
is put and no deeper, the sag under gravity scales as 1/E and does not change with dt, a grasper carries the edge
it holds where its jaws go while a scalpel cuts beside it."""

from pathlib import Path

import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.commands.view import scene_hybrid
from tissuesim.recording import read_recording
from tissuesim.scene import Simulation, parse_scene, read_scene

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCENES = sorted(EXAMPLES.glob("*.toml"))


def _simulation(name: str, **replace) -> Simulation:
    """The example ``name`` with each text ``old`` of ``replace`` replaced (``{old: new}``), ready to run."""
    path = EXAMPLES / f"{name}.toml"
    text = path.read_text()
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    loaded = parse_scene(text, path)
    return Simulation(loaded, scene_hybrid(loaded, progress=False)[0])


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_every_example_is_a_valid_scene(path):
    loaded = read_scene(path)
    assert loaded.scene.title and loaded.scene.run.steps <= 100     # fast enough for a test


def test_the_probe_presses_as_deep_as_it_is_put():
    simulation = _simulation("probe_block")
    summary = simulation.run()
    probe = simulation.tools[0].tool
    depth = 0.080 - (0.092 - probe.radius)          # the top face at 80 mm, the sphere's lowest point below it
    top = int(np.argmin(np.linalg.norm(simulation.solver.rest_positions - [0.0, 0.0, 0.08], axis=1)))
    assert simulation.solver.displacements[top, 2] == pytest.approx(-depth, rel=0.05)
    assert probe.gaps().min() >= -probe.tolerance                    # no vertex inside the probe
    force = summary.forces["probe"]
    assert force[2] < 0 and np.linalg.norm(force[:2]) < 0.05 * -force[2]    # frictionless: straight down


def test_the_sag_under_gravity_scales_as_one_over_e_and_not_with_dt():
    sags = {}
    for stiffer in (False, True):
        for dt in ("0.01", "0.02"):
            material = 'preset = "fat"\nyoungs_modulus = 6500.0\n' if stiffer else 'preset = "fat"\n'
            simulation = _simulation("hanging_sphere", **{'preset = "fat"\n': material, "dt = 0.01": f"dt = {dt}"})
            simulation.run()
            bottom = int(np.argmin(simulation.solver.rest_positions[:, 2]))
            sags[stiffer, dt] = simulation.solver.displacements[bottom]
    assert sags[False, "0.01"][2] < -1e-3                             # it hangs: the bottom goes down
    assert np.allclose(sags[False, "0.02"], sags[False, "0.01"], rtol=1e-9, atol=0)
    assert np.allclose(sags[True, "0.01"], sags[False, "0.01"] * 3250.0 / 6500.0, rtol=1e-9, atol=0)


def test_the_liver_is_retracted_and_cut_beside_it(tmp_path):
    record = tmp_path / "liver.pvd"
    assert main(["run", str(EXAMPLES / "liver_retraction.toml"), "--quiet", "--record", str(record)]) == 0
    frames = read_recording(record)
    assert frames[0].time == 0.0 and 0.41 <= frames[-1].time <= 0.5     # a frame after the stroke (none at rest)
    assert len(frames[-1].cut_edges) > 0 and len(frames[-1].positions) > len(frames[0].positions)
    assert np.allclose(frames[-1].tools.graspers, [[0.1128, -0.0046, 0.0378, 0.008]], atol=1e-12)   # the jaws
    held = np.flatnonzero(np.any(frames[-1].force, axis=1))             # the jaws' forces, on what they hold
    assert 1 <= len(held) <= 10
    pull = frames[-1].force[held].sum(axis=0)
    assert pull[0] > 0.5 and np.linalg.norm(pull[1:]) < 0.5 * pull[0]  # outward
    moved = frames[-1].displacement[held]            # from rest: settled under gravity, then carried 15 mm outward
    assert np.all((0.015 < moved[:, 0]) & (moved[:, 0] < 0.02))
    assert frames[-1].displacement[:, 2].mean() < 0                   # and the whole organ sags


def test_the_run_command_says_what_it_did(tmp_path, capsys):
    assert main(["run", str(EXAMPLES / "probe_block.toml"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "50 steps, 0.5 s simulated" in out and "largest displacement" in out and "probe: force" in out
