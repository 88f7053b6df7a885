"""Recording for ParaView (.pvd + VTU through meshio) and reading it back."""

import numpy as np
import pytest

from tissuesim import HybridMesh, make_solver
from tissuesim.mesh import models
from tissuesim.recording import Recorder, RecordingError, border_edges, read_recording, solver_frame


@pytest.fixture(scope="module")
def solver():
    return make_solver("pbd", HybridMesh.build(models.cube(resolution=150), fine_volume=False))


def test_border_edges_are_the_edges_of_one_triangle_only():
    closed = models.cube(resolution=60).triangles
    assert border_edges(closed).shape == (0, 2)  # a closed surface has no cut
    opened = closed[1:]  # one triangle removed: its three edges are now borders
    assert {tuple(e) for e in border_edges(opened)} == {tuple(sorted(e)) for e in
                                                        closed[0][[[0, 1], [1, 2], [2, 0]]].tolist()}


def test_frames_round_trip_with_positions_displacement_force_and_cut_edges(solver, tmp_path):
    solver.reset()
    node = int(np.argmax(solver.rest_positions[:, 2]))
    with Recorder(tmp_path / "session.pvd") as recorder:
        recorder.add(solver_frame(solver, 0.0))
        solver.set_load(node, [0.0, 0.0, 0.5])
        for _ in range(3):
            solver.step()
        frame = solver_frame(solver, 0.03)
        cut = frame.triangles[1:]  # a frame whose surface is open along one triangle's edges
        recorder.add(frame.__class__(frame.time, frame.positions, cut, frame.displacement, frame.force,
                                     border_edges(cut)))
    frames = read_recording(tmp_path / "session.pvd")
    assert [f.time for f in frames] == [0.0, 0.03]
    assert np.allclose(frames[1].positions, solver.positions)
    assert np.allclose(frames[1].displacement, solver.positions - solver.rest_positions)
    assert np.allclose(frames[1].force[node], [0.0, 0.0, 0.5]) and np.count_nonzero(frames[1].force) == 1
    assert len(frames[0].cut_edges) == 0 and len(frames[1].cut_edges) == 3
    assert np.array_equal(frames[1].triangles, cut)
    assert (tmp_path / "session_frames" / "frame_000001.vtu").is_file()


def test_a_recording_that_is_not_a_pvd_or_has_no_folder_is_refused(tmp_path):
    with pytest.raises(RecordingError, match=".pvd"):
        Recorder(tmp_path / "session.vtu")
    with pytest.raises(RecordingError, match="does not exist"):
        Recorder(tmp_path / "missing" / "session.pvd")
    with pytest.raises(RecordingError, match="no recording"):
        read_recording(tmp_path / "none.pvd")
    (tmp_path / "bad.pvd").write_text("not xml")
    with pytest.raises(RecordingError, match="not a ParaView collection"):
        read_recording(tmp_path / "bad.pvd")
