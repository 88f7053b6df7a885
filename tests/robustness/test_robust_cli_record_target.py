"""``tissuesim run --record`` into a place where nothing can be written (/proc, a file system that refuses new
folders) is refused up front, in one line, before the mesh is built, not after the whole run."""

import os

import pytest

from tissuesim.cli import main
from tissuesim.recording_place import RecordingError, check_target

SCENE = '[model]\nname = "cube"\nresolution = 200\n[run]\nduration = 0.02\n'


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="no /proc on this system")
def test_a_recording_into_proc_is_refused_before_the_mesh_is_built(tmp_path, capsys):
    (tmp_path / "scene.toml").write_text(SCENE)
    assert main(["run", str(tmp_path / "scene.toml"), "--quiet", "--record", "/proc/x.pvd"]) == 1
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == "" and len(lines) == 1          # no mesh announced, no steps taken
    assert lines[0].startswith("tissuesim run: error: cannot record to '/proc/x.pvd': folder '/proc'")
    assert "cannot be written" in lines[0]


def test_the_check_writes_for_real_and_leaves_nothing(tmp_path, monkeypatch):
    def refused(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    before = sorted(os.listdir(tmp_path))
    check_target(tmp_path / "a.pvd")
    assert sorted(os.listdir(tmp_path)) == before
    monkeypatch.setattr(os, "mkdir", refused)             # a folder the permission bits do not tell (root, ACLs)
    with pytest.raises(RecordingError, match=r"cannot be written \(creating a folder there failed: Permission "
                                             r"denied\); record into another folder"):
        check_target(tmp_path / "a.pvd")
    assert sorted(os.listdir(tmp_path)) == before
