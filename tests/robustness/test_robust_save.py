"""Sweep item 12: saving a bundle never replaces something that is not a regular file."""

import os
import stat

import pytest

from tissuesim import BundleError


def test_saving_onto_a_pipe_is_refused_and_leaves_it(small_cube, tmp_path):
    pipe = tmp_path / "pipe.npz"
    os.mkfifo(pipe)
    with pytest.raises(BundleError, match="not a regular file"):
        small_cube.save(pipe)
    assert stat.S_ISFIFO(pipe.stat().st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe.npz"]


def test_saving_onto_a_folder_is_refused(small_cube, tmp_path):
    with pytest.raises(BundleError, match="not a regular file"):
        small_cube.save(tmp_path)
