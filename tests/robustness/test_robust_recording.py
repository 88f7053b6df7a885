"""Hostile recordings: damaged or foreign ones read back, clashing targets, re-recording, a tissue at rest."""

import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.recording import FLUSH_EVERY, Frame, Recorder, RecordingError, border_edges, read_recording

# a closed tetrahedron's surface: 4 points, 4 outward triangles
POINTS = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]])
TRIANGLES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.int32)


def frame(time=0.0, shift=0.0, force=0.0, triangles=TRIANGLES):
    """A frame of the tetrahedron moved by ``shift`` [m] along x, with ``force`` [N] on point 3."""
    positions = POINTS + [shift, 0.0, 0.0]
    forces = np.zeros((4, 3))
    forces[3, 2] = force
    return Frame(time, positions, triangles, positions - POINTS, forces, border_edges(triangles))


def record(path, shifts):
    """A recording at ``path`` of one frame per entry of ``shifts`` [m], 10 ms apart."""
    with Recorder(path) as recorder:
        for i, shift in enumerate(shifts):
            recorder.add(frame(0.01 * i, shift))
    return path


def second_frame(pvd):
    """The VTU file of the second frame of the recording ``pvd`` (as :func:`record` names it)."""
    return pvd.parent / "s_frames" / "frame_000001.vtu"


def rewrite_second_frame(pvd, points, cells, **point_data):
    """Replace the second frame of ``pvd`` by a VTU of ``points`` and ``cells`` with ``point_data`` (by default a
    zero displacement and force at every point)."""
    import meshio

    zeros = np.zeros((len(points), 3))
    point_data = point_data or {"displacement": zeros, "force": zeros}
    meshio.Mesh(points, cells, point_data=point_data).write(second_frame(pvd), binary=True)


def tree(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


# ------------------------------------------------------------------------------------- damaged or foreign recordings
def missing_vtu(pvd):
    second_frame(pvd).unlink()


def tets_only(pvd):
    rewrite_second_frame(pvd, POINTS, [("tetra", [[0, 1, 2, 3]])])


def no_displacement(pvd):
    rewrite_second_frame(pvd, POINTS, [("triangle", TRIANGLES)], force=np.zeros((4, 3)))


def index_out_of_range(pvd):
    rewrite_second_frame(pvd, POINTS, [("triangle", TRIANGLES + 2)])


def dataset_without_file(pvd):
    pvd.write_text(pvd.read_text().replace('file="s_frames/frame_000001.vtu"', ""))


def wrong_shape(pvd):
    rewrite_second_frame(pvd, POINTS, [("triangle", TRIANGLES)], displacement=np.zeros((4, 2)),
                         force=np.zeros((4, 3)))


def nan_positions(pvd):
    points = POINTS.copy()
    points[2, 1] = np.nan
    rewrite_second_frame(pvd, points, [("triangle", TRIANGLES)])


def truncated(pvd):
    vtu = second_frame(pvd)
    data = vtu.read_bytes()
    vtu.write_bytes(data[: len(data) // 2])


def far_points(pvd):  # polyscope's view of such a frame blocked in a modal dialog that only SIGKILL ended
    rewrite_second_frame(pvd, POINTS + 1e298, [("triangle", TRIANGLES)])


def all_in_one_place(pvd):
    rewrite_second_frame(pvd, np.zeros((4, 3)), [("triangle", TRIANGLES)])


def single_point(pvd):
    rewrite_second_frame(pvd, POINTS[:1], [("triangle", [[0, 0, 0]])])


DAMAGES = {  # damage -> (what the message must say, the file it must name)
    missing_vtu: ("missing", "frame_000001.vtu"),
    tets_only: ("no triangles (cells: tetra)", "frame_000001.vtu"),
    no_displacement: ("no point data 'displacement'", "frame_000001.vtu"),
    index_out_of_range: ("4 triangle cells name points outside 0..3", "frame_000001.vtu"),
    dataset_without_file: ("<DataSet> 1 names no file", "s.pvd"),
    wrong_shape: ("'displacement' has shape (4, 2), expected (4, 3)", "frame_000001.vtu"),
    nan_positions: ("1 points have non-finite positions (first points 2)", "frame_000001.vtu"),
    truncated: ("truncated or not a VTU file", "frame_000001.vtu"),
    far_points: ("4 points lie farther than 1e+06 m from the origin", "frame_000001.vtu"),
    all_in_one_place: ("its 4 points span 0 m, less than 1e-09 m", "frame_000001.vtu"),
    single_point: ("its 1 points span 0 m", "frame_000001.vtu"),
}


@pytest.mark.parametrize("damage", DAMAGES, ids=lambda damage: damage.__name__)
def test_a_damaged_recording_is_refused_naming_the_file_and_the_defect(tmp_path, damage):
    pvd = record(tmp_path / "s.pvd", [0.0, 0.001, 0.002])
    damage(pvd)
    said, where = DAMAGES[damage]
    with pytest.raises(RecordingError) as error:  # never meshio's SystemExit, which would end the caller
        read_recording(pvd)
    assert said in str(error.value) and where in str(error.value)


@pytest.mark.parametrize("damage", DAMAGES, ids=lambda damage: damage.__name__)
def test_view_replay_of_a_damaged_recording_prints_one_line_and_exits_1(tmp_path, capsys, damage):
    pvd = record(tmp_path / "s.pvd", [0.0, 0.001, 0.002])
    damage(pvd)
    assert main(["view", "--replay", str(pvd)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and DAMAGES[damage][0] in err


# ------------------------------------------------------------------------------------------------ the target
@pytest.mark.parametrize("clash", ["frames_is_a_file", "pvd_is_a_folder"])
def test_a_target_that_cannot_hold_a_recording_is_refused_before_the_session(tmp_path, capsys, clash):
    pvd = tmp_path / "clash.pvd"
    if clash == "frames_is_a_file":
        (tmp_path / "clash_frames").write_text("something else")
    else:
        pvd.mkdir()
    before = tree(tmp_path)
    with pytest.raises(RecordingError, match="which is a file" if clash == "frames_is_a_file" else "is a folder"):
        Recorder(pvd)
    # the command says so before it builds a mesh or opens a window
    assert main(["view", "cube", "--record", str(pvd)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot record to" in err and "clash" in err
    assert tree(tmp_path) == before  # nothing written


# --------------------------------------------------------------------------------------------- re-recording
def test_a_finished_re_recording_replaces_the_old_one_and_leaves_nothing_else(tmp_path):
    record(tmp_path / "s.pvd", [0.0, 0.001, 0.002, 0.003])
    record(tmp_path / "s.pvd", [0.0, 0.005])
    frames = read_recording(tmp_path / "s.pvd")
    assert [f.positions[0, 0] for f in frames] == [0.0, 0.005]  # assigned values, written and read as float64
    assert tree(tmp_path) == ["s.pvd", "s_frames", "s_frames/frame_000000.vtu", "s_frames/frame_000001.vtu"]
    (tmp_path / "plain").mkdir()  # the frames folder is made as any folder (the umask), readable by whom it allows
    assert (tmp_path / "s_frames").stat().st_mode == (tmp_path / "plain").stat().st_mode


def test_an_interrupted_or_failed_re_recording_leaves_the_old_one_intact(tmp_path):
    record(tmp_path / "s.pvd", [0.0, 0.001, 0.002])
    old = np.array([f.positions for f in read_recording(tmp_path / "s.pvd")])
    interrupted = Recorder(tmp_path / "s.pvd")  # a session that dies without closing (a killed process)
    for i in range(FLUSH_EVERY + 1):
        interrupted.add(frame(0.01 * i, 0.01 + 1e-4 * i))
    np.testing.assert_array_equal([f.positions for f in read_recording(tmp_path / "s.pvd")], old)  # bit for bit
    partial = [p for p in tmp_path.iterdir() if ".partial-" in p.name]
    assert len(partial) == 1 and len(read_recording(partial[0] / "s.pvd")) == FLUSH_EVERY  # readable on its own
    with pytest.raises(ZeroDivisionError):
        with Recorder(tmp_path / "s.pvd") as failing:
            failing.add(frame(0.0, 0.02))
            1 / 0
    np.testing.assert_array_equal([f.positions for f in read_recording(tmp_path / "s.pvd")], old)  # bit for bit
    assert [p for p in tmp_path.iterdir() if ".partial-" in p.name] == partial  # the failed one left nothing


def test_every_panel_recording_gets_its_own_name(tmp_path):
    from tissuesim.recording_place import session_path

    first = session_path(tmp_path)
    record(first, [0.0])
    second = session_path(tmp_path)  # within the same second: a suffix
    assert second != first and second.parent == tmp_path and second.suffix == ".pvd"
    record(second, [0.0, 0.001])
    assert len(read_recording(first)) == 1 and len(read_recording(second)) == 2


# ------------------------------------------------------------------------------------------------ at rest
def test_a_tissue_at_rest_writes_no_frames_and_every_change_writes_one(tmp_path):
    from tissuesim.recording import MIN_MOTION

    with Recorder(tmp_path / "s.pvd") as recorder:
        written = [recorder.add(frame(0.01 * i)) for i in range(100)]  # at rest: the first frame only
        assert written == [True] + [False] * 99
        # motion is measured from the last frame written, so a slow creep is written once it adds up
        creep = [recorder.add(frame(1.0 + 0.01 * i, 0.6 * MIN_MOTION * i)) for i in range(1, 5)]
        assert creep == [False, True, False, True]
        assert recorder.add(frame(2.0, 2.4 * MIN_MOTION, force=0.5))  # the load changed, nothing moved yet
        assert recorder.add(frame(2.1, 2.4 * MIN_MOTION, force=0.5, triangles=TRIANGLES[1:]))  # a cut
    assert len(read_recording(tmp_path / "s.pvd")) == 5


# ------------------------------------------------------------------------------------- partial folders, links
def dead_pid():
    """The id of a process that has ended (its own child, waited for)."""
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_a_new_recording_removes_the_partials_of_killed_sessions_of_its_name_only(tmp_path):
    import os

    dead = dead_pid()
    stale = tmp_path / f"s_frames.partial-{dead}-0"
    stale.mkdir()
    (stale / "frame_000000.vtu").write_text("half")
    (tmp_path / f"s_frames.partial-{dead}-1-old").symlink_to(stale)    # a link is removed as a link
    live = tmp_path / f"s_frames.partial-{os.getppid()}-0"                 # a session still running
    live.mkdir()
    other = tmp_path / f"t_frames.partial-{dead}-0"                        # another recording's
    other.mkdir()
    record(tmp_path / "s.pvd", [0.0])
    assert tree(tmp_path) == sorted(["s.pvd", "s_frames", "s_frames/frame_000000.vtu", live.name, other.name])


def test_a_partial_recording_is_readable_from_its_first_frame(tmp_path):
    recorder = Recorder(tmp_path / "s.pvd")  # a session killed after one frame
    recorder.add(frame(0.0))
    partial = [p for p in tmp_path.iterdir() if ".partial-" in p.name]
    assert len(partial) == 1 and len(read_recording(partial[0] / "s.pvd")) == 1
    recorder.abort()


def test_re_recording_over_a_linked_frames_folder_leaves_no_link_behind(tmp_path):
    record(tmp_path / "real.pvd", [0.0, 0.001])
    (tmp_path / "x_frames").symlink_to(tmp_path / "real_frames")
    record(tmp_path / "x.pvd", [0.0])
    assert tree(tmp_path) == ["real.pvd", "real_frames", "real_frames/frame_000000.vtu",
                              "real_frames/frame_000001.vtu", "x.pvd", "x_frames", "x_frames/frame_000000.vtu"]
    assert not (tmp_path / "x_frames").is_symlink() and len(read_recording(tmp_path / "real.pvd")) == 2


# ------------------------------------------------------------------------------------------------ small checks
@pytest.mark.parametrize("min_motion", [True, "1e-3", None])
def test_min_motion_is_a_distance(tmp_path, min_motion):
    with pytest.raises(RecordingError, match="min_motion must be a finite distance"):
        Recorder(tmp_path / "s.pvd", min_motion=min_motion)
    assert tree(tmp_path) == []


@pytest.mark.parametrize("name, said", [
    ("a" * 300 + ".pvd", "name too long"),        # the .pvd itself
    ("b" * 240 + ".pvd", "the name is too long"),  # its frames folder's temporary name
])
def test_a_name_too_long_is_a_recording_error_before_anything_is_written(tmp_path, name, said):
    with pytest.raises(RecordingError, match=said):
        Recorder(tmp_path / name)
    assert tree(tmp_path) == []


def test_an_empty_name_is_said_to_be_empty():
    with pytest.raises(RecordingError, match="got an empty one"):
        Recorder("")


def test_reading_a_recording_can_show_its_progress(tmp_path, capsys):
    frames = read_recording(record(tmp_path / "s.pvd", [0.0, 0.001]), progress=True)
    assert len(frames) == 2 and "reading" in capsys.readouterr().err
