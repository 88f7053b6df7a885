"""CLI outputs: an interrupted run leaves an earlier run's folder as it was; a finished run says what it replaced."""

import meshio
import pytest

from tissuesim.cli import main
from tissuesim.solvers import method_names

CUBE = ["cube", "--resolution", "300"]   # a coarse cube: the scripted incision takes well under a second
#: the methods a run cuts beside pbd: those the scalpel cuts whose step is the static answer (no settling by steps,
#: so the scripted incision stays well under a second; the hybrid's ``static`` depends on its options)
STATIC_CUTTING = method_names(cuts=True, where=lambda cls: cls.static_by_default())


def _snapshot(folder):
    """Every file under ``folder`` (hidden ones included) with its bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_an_interrupted_incise_leaves_the_earlier_folder_as_it_was(tmp_path, monkeypatch, capsys):
    out = tmp_path / "cut"
    assert main(["incise", *CUBE, "--methods", "pbd", "--output", str(out)]) == 0
    before = _snapshot(out)
    # a different run (finer cube, more methods), interrupted while writing its first VTU: its OBJ is written by then
    calls = []

    def interrupted(*args, **kwargs):
        calls.append(args)
        raise KeyboardInterrupt

    monkeypatch.setattr(meshio, "write", interrupted)
    code = main(["incise", "cube", "--resolution", "400", "--methods", "pbd", *STATIC_CUTTING, "--output", str(out)])
    assert code == 130 and calls                      # the interruption happened, while writing
    assert _snapshot(out) == before                   # no new, truncated or replaced file
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut"]     # no staging folder left beside it
    assert capsys.readouterr().err.strip().splitlines()[-1] == "tissuesim incise: interrupted"


def test_incise_replaces_an_earlier_run_as_a_whole_and_says_so(tmp_path, capsys):
    out = tmp_path / "cut"
    assert STATIC_CUTTING
    assert main(["incise", *CUBE, "--methods", "pbd", *STATIC_CUTTING, "--output", str(out)]) == 0
    (out / "notes.txt").write_text("the user's own file")
    capsys.readouterr()
    assert main(["incise", *CUBE, "--methods", "pbd", "--output", str(out)]) == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == ["cube_pbd.obj", "cube_pbd.vtu", "incision.json", "incision.md", "notes.txt"]
    note = [line for line in capsys.readouterr().err.splitlines() if "earlier results" in line]
    others = sorted(f"cube_{method}.{ext}" for method in STATIC_CUTTING for ext in ("obj", "vtu"))
    assert note == [f"{out}: earlier results replaced 4 (cube_pbd.obj, cube_pbd.vtu, incision.json, incision.md); "
                    f"removed {len(others)} not written by this run ({', '.join(others)})"]


def test_experiment_says_which_earlier_files_it_removes(tmp_path, monkeypatch, capsys, synthetic_results):
    from tissuesim.experiments import run

    out = tmp_path / "results"
    monkeypatch.setattr(run, "run_experiment", lambda config, progress: synthetic_results(models=config.models))
    assert main(["experiment", "cube", "liver", "--quick", "--quiet", "--output", str(out)]) == 0
    assert (out / "radar_liver.png").is_file()
    capsys.readouterr()
    assert main(["experiment", "cube", "--quick", "--quiet", "--output", str(out)]) == 0
    assert not (out / "radar_liver.png").exists()
    err = capsys.readouterr().err
    assert (f"{out}: earlier results replaced 4 (radar_cube.png, report.md, results.json, tables.md); removed 1 not "
            "written by this run (radar_liver.png)") in err.splitlines()


def test_a_first_run_into_a_new_folder_says_nothing_of_earlier_results(tmp_path, capsys):
    assert main(["incise", *CUBE, "--methods", "pbd", "--output", str(tmp_path / "new")]) == 0
    assert "earlier results" not in capsys.readouterr().err


@pytest.mark.parametrize("cache", ["", "  "])
def test_an_empty_cache_folder_is_refused_not_replaced_by_the_default(cache, tmp_path, capsys):
    assert main(["experiment", "--protocol", "contact", "--quick", "--quiet", "--cache", cache,
                 "--output", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("tissuesim experiment: error: --cache is empty") and err.count("\n") == 1


def test_a_full_disk_while_writing_is_one_line_and_leaves_no_file(tmp_path, monkeypatch, capsys):
    import errno

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(meshio, "write", full)
    out = tmp_path / "cut"
    assert main(["incise", *CUBE, "--methods", "pbd", "--output", str(out)]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == (f"tissuesim incise: error: cannot write the results into {str(out)!r}: "
                                            "No space left on device; the folder is left as it was")
    assert list(tmp_path.iterdir()) == []
