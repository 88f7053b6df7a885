"""CLI output folders: only our own earlier files are removed, a folder on another file system or under a read-only
parent is written, and the swap into an existing folder is all or nothing."""

import errno
import json
import os
import tempfile
from pathlib import Path

import pytest

from tissuesim.cli import main
from tissuesim.experiments import output

CUBE = ["cube", "--resolution", "300"]   # a coarse cube: the scripted incision takes well under a second


def _snapshot(folder):
    """Every file under ``folder`` (hidden ones included) with its bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_incise_leaves_the_users_files_alone_whatever_their_names(tmp_path, capsys):
    data = tmp_path / "data"
    data.mkdir()
    own = {"scan_hybrid.obj": "the input", "notes_fem.vtu": "notes", "keep_mass-spring.obj": "kept",
           "report.md": "mine"}
    for name, text in own.items():
        (data / name).write_text(text)
    capsys.readouterr()
    assert main(["incise", *CUBE, "--methods", "pbd", "-o", str(data)]) == 0
    assert {name: (data / name).read_text() for name in own} == own
    assert "earlier results" not in capsys.readouterr().err
    # a second run removes the first run's files that its incision.json lists, and nothing else
    (data / "cube_embedded.obj").write_text("not listed by the earlier run")
    assert main(["incise", *CUBE, "--methods", "embedded", "-o", str(data)]) == 0
    assert not (data / "cube_pbd.obj").exists() and not (data / "cube_pbd.vtu").exists()
    assert {name: (data / name).read_text() for name in own} == own


def test_experiment_leaves_files_its_index_does_not_list(tmp_path, monkeypatch, synthetic_results):
    from tissuesim.experiments import run

    out = tmp_path / "out"
    out.mkdir()
    (out / "radar_notes.png").write_text("the user's own plot")
    monkeypatch.setattr(run, "run_experiment", lambda config, progress: synthetic_results(models=config.models))
    assert main(["experiment", "cube", "--quick", "--quiet", "--output", str(out)]) == 0
    assert (out / "radar_notes.png").read_text() == "the user's own plot"


def test_a_paper_run_removes_an_earlier_contact_runs_figure(tmp_path, synthetic_results):
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.json").write_text(json.dumps({"schema": "tissuesim-contact/1"}))
    (out / "errors.png").write_text("an earlier contact run's figure")
    written = output.write_outputs(synthetic_results(models=("cube",)), out, plots=False)
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in written)


def _other_file_system(monkeypatch, mount: Path):
    """Make ``mount`` a mount point: a rename into or out of it from elsewhere fails with EXDEV, as the kernel's."""
    inside = lambda path: Path(path).resolve() == mount or mount in Path(path).resolve().parents  # noqa: E731

    def guarded(real):
        def move(source, destination, *args, **kwargs):
            if inside(source) != inside(destination):
                raise OSError(errno.EXDEV, "Invalid cross-device link", str(source), None, str(destination))
            return real(source, destination, *args, **kwargs)
        return move

    monkeypatch.setattr(os, "replace", guarded(os.replace))
    monkeypatch.setattr(os, "rename", guarded(os.rename))


def test_incise_writes_into_a_mount_point(tmp_path, monkeypatch, capsys):
    mount = tmp_path / "full"
    mount.mkdir()
    (mount / "incision.md").write_text("an old table")
    _other_file_system(monkeypatch, mount.resolve())
    assert main(["incise", *CUBE, "--methods", "pbd", "-o", str(mount)]) == 0, capsys.readouterr().err
    assert sorted(p.name for p in mount.iterdir()) == ["cube_pbd.obj", "cube_pbd.vtu", "incision.json",
                                                      "incision.md"]


@pytest.mark.parametrize("command", [["incise", *CUBE, "--methods", "pbd"], ["render", "--if-available", *CUBE]])
def test_a_writable_folder_under_a_read_only_parent_is_accepted(command, tmp_path, monkeypatch, capsys):
    target = tmp_path / "ro" / "res"
    target.mkdir(parents=True)
    real = tempfile.mkdtemp

    def read_only_parent(*args, dir=None, **kwargs):
        if Path(dir).resolve() == target.parent.resolve():
            raise PermissionError(errno.EROFS, "Read-only file system", str(dir))
        return real(*args, dir=dir, **kwargs)

    monkeypatch.setattr(tempfile, "mkdtemp", read_only_parent)
    monkeypatch.chdir(target)
    code = main([*command, "-o", "."])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "Read-only" not in err


def _staged_into(folder, names):
    """Write files ``names`` (text: their own name) into ``folder`` through the staging protocol."""
    def fill(staging):
        for name in names:
            (staging / name).write_text(f"new {name}")
    return output.write_staged(folder, fill, ours=lambda f: {"old_only.txt", *names})


def test_an_interrupted_swap_moves_everything_back(tmp_path, monkeypatch):
    target = tmp_path / "out"
    target.mkdir()
    for name in ("a.obj", "b.vtu", "old_only.txt", "mine.txt"):
        (target / name).write_text(f"old {name}")
    before = _snapshot(target)
    real, calls = os.replace, []

    def third_interrupted(*args, **kwargs):
        calls.append(args)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(os, "replace", third_interrupted)
    with pytest.raises(KeyboardInterrupt):
        _staged_into(target, ["a.obj", "b.vtu", "c.md"])
    assert len(calls) > 3                               # the interruption came mid-swap, and the moves were undone
    assert _snapshot(target) == before                  # no staging folder left inside either


def test_a_folder_in_the_way_is_refused_before_anything_moves(tmp_path, capsys):
    out = tmp_path / "cut"
    (out / "incision.json").mkdir(parents=True)
    (out / "cube_pbd.obj").write_text("old surface")
    assert main(["incise", *CUBE, "--methods", "pbd", "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "cube: pbd" not in err                       # refused before the first cut
    assert "incision.json there is a folder" in err.splitlines()[-1] and ".partial" not in err
    assert sorted(p.name for p in out.iterdir()) == ["cube_pbd.obj", "incision.json"]
    assert (out / "cube_pbd.obj").read_text() == "old surface"


def test_an_index_naming_a_file_outside_the_folder_removes_nothing_there(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "x_pbd.obj").write_text("outside the folder")
    (out / "incision.json").write_text(json.dumps([{"model": "../x", "method": "pbd"}]))
    from tissuesim.commands.incise import incision_files

    output.write_staged(out, lambda staging: (staging / "incision.json").write_text("[]"), ours=incision_files)
    assert (tmp_path / "x_pbd.obj").read_text() == "outside the folder"


def test_incise_refuses_to_write_over_one_of_its_inputs(tmp_path, capsys):
    from tissuesim import write_surface
    from tissuesim.mesh import models

    data = tmp_path / "data"
    data.mkdir()
    victim = data / "cube_pbd.obj"                       # the name the cube's pbd surface is written under
    write_surface(victim, models.sphere(resolution=300))
    before = victim.read_bytes()
    assert main(["incise", "cube", str(victim), "--resolution", "300", "--methods", "pbd", "-o", str(data)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == (f"tissuesim incise: error: the model file {victim} would be replaced by this run's "
                       f"cube_pbd.obj in {data}; give another --output or move the model file")
    assert victim.read_bytes() == before
