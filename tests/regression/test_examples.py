"""The examples double as regression tests: each runs as a user would run it."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _example(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


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
    if result["scalpel"]:
        assert len(frames[-1].cut_edges) == result["cut_edges"] > 0
        assert len(frames[-1].positions) == len(frames[0].positions) + result["vertices_added"] > len(frames[0].positions)
