"""An output or recording path under a file (``afile/results``) is told as such, with the fix: the messages said the
file "does not exist"."""

import pytest

from tissuesim.experiments.output import OutputError, check_output_folder
from tissuesim.recording_place import RecordingError, check_target


def test_an_output_folder_under_a_file_names_the_file(tmp_path):
    (tmp_path / "afile").write_text("")
    with pytest.raises(OutputError, match=r"its parent '.*afile' is a file, not a folder; .*--output"):
        check_output_folder(tmp_path / "afile" / "results")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


def test_a_missing_parent_says_to_create_it(tmp_path):
    with pytest.raises(OutputError, match=r"its parent '.*missing' does not exist; create it"):
        check_output_folder(tmp_path / "missing" / "results")


def test_a_recording_under_a_file_names_the_file(tmp_path):
    (tmp_path / "afile").write_text("")
    with pytest.raises(RecordingError, match=r"folder '.*afile' is a file, not a folder; record into a folder"):
        check_target(tmp_path / "afile" / "run.pvd")
    with pytest.raises(RecordingError, match=r"folder '.*missing' does not exist; create it or record into"):
        check_target(tmp_path / "missing" / "run.pvd")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]
