"""Sweep item 11: the experiment's results folder — checked before the run, replaced whole, no leftovers."""

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

import tissuesim
from tissuesim.cli import main
from tissuesim.experiments import output

SRC = Path(tissuesim.__file__).resolve().parents[1]      # the package under test, for the child process


def test_a_place_where_staging_fails_is_refused_before_the_run(tmp_path, monkeypatch):
    target = tmp_path / "p" / "out"
    target.mkdir(parents=True)              # the folder exists, so its results are staged inside it
    real = tempfile.mkdtemp

    def unwritable_folder(*args, dir=None, **kwargs):
        if Path(dir) == target.resolve():
            raise PermissionError(13, "Permission denied", str(dir))
        return real(*args, dir=dir, **kwargs)

    monkeypatch.setattr(tempfile, "mkdtemp", unwritable_folder)
    with pytest.raises(output.OutputError, match="creating in .*out.* failed .Permission denied"):
        output.check_output_folder(target)


def test_results_of_another_run_are_replaced_as_a_whole(tmp_path, synthetic_results):
    target = tmp_path / "out"
    output.write_outputs(synthetic_results(models=("cube", "liver")), target)
    assert (target / "radar_liver.png").is_file()
    (target / "notes.txt").write_text("the user's own file")
    output.write_outputs(synthetic_results(models=("cube",)), target)
    names = sorted(p.name for p in target.iterdir())
    assert names == ["notes.txt", "radar_cube.png", "report.md", "results.json", "tables.md"]


def test_the_folder_follows_the_umask(tmp_path, synthetic_results):
    previous = os.umask(0o022)
    try:
        output.write_outputs(synthetic_results(), tmp_path / "out", plots=False)
    finally:
        os.umask(previous)
    assert (tmp_path / "out").stat().st_mode & 0o777 == 0o755


def test_an_empty_output_path_is_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["experiment", "cube", "--quick", "--quiet", "--output", ""]) == 1
    assert "output path is empty" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_a_staging_folder_of_a_killed_run_is_removed(tmp_path, synthetic_results):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    abandoned = tmp_path / f".out.partial-{dead.pid}-x1y2"
    abandoned.mkdir()
    (abandoned / "results.json").write_text("{}")
    output.write_outputs(synthetic_results(), tmp_path / "out", plots=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# SIGTERM while the files are being written: the staging folder must go, and the CLI must say so in one line.
TERMINATED_RUN = """
import json, os, signal, sys, time
from tissuesim import cli
from tissuesim.experiments import output, run
data = json.load(open(sys.argv[1]))
run.run_experiment = lambda config, progress: data
output.report_markdown = lambda data: (os.kill(os.getpid(), signal.SIGTERM), time.sleep(30))
sys.exit(cli.main(["experiment", "cube", "--quick", "--quiet", "--no-plots", "-o", sys.argv[2]]))
"""


def test_sigterm_while_writing_leaves_no_staging_folder(tmp_path, synthetic_results):
    data = tmp_path / "data.json"
    data.write_text(json.dumps(synthetic_results()))
    target = tmp_path / "results" / "out"
    target.parent.mkdir()
    environment = {**os.environ, "PYTHONPATH": str(SRC)}
    done = subprocess.run([sys.executable, "-c", TERMINATED_RUN, str(data), str(target)], capture_output=True,
                          text=True, env=environment, timeout=60)
    assert done.returncode == 143, done.stderr
    assert done.stderr.strip().splitlines() == ["tissuesim experiment: terminated"]
    assert list(target.parent.iterdir()) == []
