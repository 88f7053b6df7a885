"""The contact protocol's reference cache and the run's arguments: a damaged entry is recomputed, the cache folder
is checked before any work, a write that fails names the folder and leaves no partial entry, an absurd --resolution
is refused at once, and an interrupt while the command line is read is one line."""

import errno
import subprocess
import sys
import tempfile

import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.experiments import contact_protocol, reference_cache
from tissuesim.experiments.reference import ContactReference, RefinementSettings

KEY = "0123456789abcdef0123456789abcdef"


def _entry(folder):
    """A small valid cache entry written the way a run writes it; returns the settings it was written with."""
    settings = RefinementSettings()
    ref = ContactReference(3, 0.004, np.ones((5, 3, 3)), np.arange(5), (), True, 5500.0, 0.3, settings, None)
    reference_cache.save_entry(folder, KEY, ref)
    return settings


def test_a_truncated_entry_is_recomputed_not_raised(tmp_path):
    settings = _entry(tmp_path)
    path = tmp_path / f"{KEY}.npz"
    assert reference_cache.load_entry(tmp_path, KEY, settings) is not None        # the whole entry reads back
    path.write_bytes(path.read_bytes()[:300])                           # as `head -c 300` leaves it
    assert reference_cache.load_entry(tmp_path, KEY, settings) is None


def _no_run(monkeypatch):
    def run_contact(*args, **kwargs):
        raise AssertionError("the run started before the cache folder was checked")
    monkeypatch.setattr(contact_protocol, "run_contact", run_contact)


def test_a_cache_path_that_is_a_file_is_refused_before_the_run(tmp_path, monkeypatch, capsys):
    _no_run(monkeypatch)
    (tmp_path / "tet.obj").write_text("a surface")
    assert main(["experiment", "cube", "--quick", "-q", "--protocol", "contact", "--cache", str(tmp_path / "tet.obj"),
                 "-o", str(tmp_path / "out")]) == 1
    assert capsys.readouterr().err == (f"tissuesim experiment: error: cache folder {tmp_path / 'tet.obj'} is a file, "
                                       "not a folder; give a folder (--cache DIR) or --no-cache\n")


def test_a_read_only_cache_folder_is_refused_before_the_run(tmp_path, monkeypatch, capsys):
    _no_run(monkeypatch)
    cache = tmp_path / "cc"
    cache.mkdir()
    real = tempfile.mkstemp

    def read_only(*args, dir=None, **kwargs):
        if str(dir) == str(cache):
            raise OSError(errno.EROFS, "Read-only file system", str(dir))
        return real(*args, dir=dir, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", read_only)
    assert main(["experiment", "cube", "--quick", "-q", "--protocol", "contact", "--cache", str(cache),
                 "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"tissuesim experiment: error: cannot write the reference cache in {cache}: Read-only")


def test_a_partial_entry_of_a_killed_run_is_removed(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    abandoned = tmp_path / f".{KEY}.{dead.pid}.npz"
    abandoned.write_bytes(b"PK\x03\x04 half an entry")
    reference_cache.check_cache_dir(tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_names_the_cache_folder_and_leaves_no_partial_entry(tmp_path, monkeypatch):
    def full(file, **arrays):
        open(file, "wb").write(b"PK")                                   # a start, then the disk is full
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(np, "savez", full)
    with pytest.raises(reference_cache.CacheError, match=f"cache entry in {tmp_path}: No space left on device"):
        _entry(tmp_path)
    assert list(tmp_path.iterdir()) == []


PAPER, CONTACT = ["experiment", "cube", "--quick", "-q"], ["experiment", "cube", "--quick", "-q", "--protocol",
                                                             "contact", "--no-cache"]


@pytest.mark.parametrize("command, resolution", [(PAPER, "1e12"), (PAPER, "1000000000"), (CONTACT, "1e12"),
                                                 (["build", "cube"], "1000000000"),
                                                 (["incise", "cube", "--methods", "pbd"], "1000000000")])
def test_an_absurd_resolution_is_refused_at_once(command, resolution, tmp_path, capsys):
    assert main([*command, "--resolution", resolution, "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"tissuesim {command[0]}: error: --resolution (vertices of a built-in model) must be a "
                              "whole number from 50 to 100000")


def test_an_interrupt_while_the_command_line_is_read_is_one_line(monkeypatch, capsys):
    from tissuesim import cli

    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert cli.main(["render", "cube"]) == 130
    assert capsys.readouterr().err == "tissuesim: interrupted\n"
