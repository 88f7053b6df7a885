"""The tools in a recording: written beside each frame, read back, checked; drawn by a replay where they were."""

import json
from pathlib import Path

import numpy as np
import pytest

from tissuesim import HybridMesh, make_solver
from tissuesim.mesh import models
from tissuesim.recording import Recorder, RecordingError, read_recording, solver_frame, tools_of

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def solver():
    return make_solver("pbd", HybridMesh.build(models.cube(resolution=150), fine_volume=False))


def test_tools_round_trip_and_a_frame_without_them_has_none(solver, tmp_path):
    solver.reset()
    tools = tools_of([(np.array([0.0, 0.0, 0.04]), np.array([0.0, 0.0, 0.05]))],
                     [(np.array([0.01, 0.0, 0.06]), 0.008)], 0.015, [(np.array([-0.01, 0.0, 0.05]), 0.004)])
    with Recorder(tmp_path / "session.pvd", min_motion=0.0) as recorder:
        recorder.add(solver_frame(solver, 0.0))
        solver.set_load(int(np.argmax(solver.rest_positions[:, 2])), [0.0, 0.0, 0.5])
        solver.step()
        recorder.add(solver_frame(solver, 0.01, tools=tools))
    first, second = read_recording(tmp_path / "session.pvd")
    assert first.tools.empty and not (tmp_path / "session_frames" / "frame_000000.tools.json").exists()
    assert np.array_equal(second.tools.pin_heads, tools.pin_heads)
    assert np.array_equal(second.tools.probes, tools.probes) and second.tools.blade_depth == 0.015
    assert np.array_equal(second.tools.graspers, [[-0.01, 0.0, 0.05, 0.004]])


@pytest.mark.parametrize("content, defect", [("{", "cannot read"), (json.dumps({"probes": [[0, 0, 0, -1.0]]}),
                                                                        "below 0"),
                                              (json.dumps({"pin_heads": [[0, 0, 0, 0, 0]]}), "cannot read"),
                                              (json.dumps({"graspers": [[0, 0, 0, 0.0]]}), "below 0")])
def test_a_damaged_tools_file_is_refused_by_name(solver, tmp_path, content, defect):
    with Recorder(tmp_path / "session.pvd") as recorder:
        recorder.add(solver_frame(solver, 0.0))
    (tmp_path / "session_frames" / "frame_000000.tools.json").write_text(content)
    with pytest.raises(RecordingError, match="frame_000000.tools.json") as refused:
        read_recording(tmp_path / "session.pvd")
    assert defect in str(refused.value)


def test_a_scene_run_records_its_grasper_and_blade(tmp_path):
    from tissuesim.cli import main

    assert main(["run", str(EXAMPLES / "liver_retraction.toml"), "--record", str(tmp_path / "liver.pvd"),
                 "--quiet"]) == 0
    frames = read_recording(tmp_path / "liver.pvd")
    last = frames[-1]
    assert last.tools.graspers.shape == (1, 4) and last.tools.blade_depth == 0.015
    assert len(last.tools.pin_heads) == 0
    assert np.allclose(last.tools.graspers[0], [0.1128, -0.0046, 0.0378, 0.008], atol=1e-9)   # the script's jaws
    assert len(frames[0].tools.graspers) == 0                               # not in play before its first keyframe
