"""Checks before the work, not after: render reads and checks every model before drawing the first and leaves no
empty folder when it fails; experiment refuses repeated loads, a contact run that would measure nothing, and names a
cut as the reason a bundle has no fine volume; render cleans images a killed run left half-written."""

import subprocess
import sys

import pytest

from tissuesim import HybridMesh
from tissuesim.cli import main
from tissuesim.experiments.wound import scripted_incision
from tissuesim.mesh import models
from tissuesim.solvers import make_solver
from tissuesim.viewer import figures
from tissuesim.viewer.gl import opengl_available

needs_opengl = pytest.mark.skipif(not opengl_available(), reason="no OpenGL: render stops before reading a model")


@pytest.fixture
def drawn(monkeypatch):
    """The names of the models render draws (nothing is drawn)."""
    names = []

    def deformation_figure(hybrid, name, path, **kwargs):
        names.append(name)
        path.write_bytes(b"\x89PNG")
        return path

    monkeypatch.setattr(figures, "deformation_figure", deformation_figure)
    return names


@needs_opengl
def test_render_fem_refuses_a_bundle_without_fine_volume_before_drawing_the_first_model(tmp_path, drawn, capsys):
    bundle = tmp_path / "b c" / "cube bundle.npz"
    HybridMesh.build(models.cube(resolution=300), fine_volume=False).save(bundle)
    out = tmp_path / "out"
    assert main(["render", "cube", str(bundle), "--resolution", "300", "--method", "fem", "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "was built without the fine volume" in err and "--no-fine-volume" in err
    assert drawn == [] and not out.exists()


@needs_opengl
def test_render_leaves_no_empty_folder_when_interrupted(tmp_path, monkeypatch, capsys):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(figures, "deformation_figure", interrupted)
    out = tmp_path / "out"
    assert main(["render", "cube", "--resolution", "300", "-o", str(out)]) == 130
    assert not out.exists()


def test_render_removes_images_a_killed_run_left_half_written(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    out = tmp_path / "out"
    out.mkdir()
    stale = out / f".deformation_cube.png.{dead.pid}.k2j4h6g8.partial.png"
    stale.write_bytes(b"\x89PNG half")
    (out / ".notes.partial.txt").write_text("not ours: no process id in its name")
    assert main(["render", "cube", "--if-available", "--resolution", "300", "-o", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == [".notes.partial.txt"]


@pytest.mark.parametrize("report, message", [("", "--report is empty"),
                                             ("/dev/null", "--report /dev/null is not a regular file")])
def test_a_report_path_is_named_as_given(report, message, tmp_path, capsys):
    assert main(["render", "cube", "--report", report, "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"tissuesim render: error: {message}") and "/dev/null/report.md" not in err


def _no_run(monkeypatch):
    from tissuesim.experiments import run

    def run_experiment(*args, **kwargs):
        raise AssertionError("the run started")
    monkeypatch.setattr(run, "run_experiment", run_experiment)


@pytest.mark.parametrize("option", [["--loads", "tension", "tension"], ["--forces", "1", "1.0"]])
def test_repeated_cases_are_refused_before_the_run(option, tmp_path, monkeypatch, capsys):
    _no_run(monkeypatch)
    assert main(["experiment", "cube", "--quick", "-q", *option, "-o", str(tmp_path / "out")]) == 1
    assert f"{option[0]} names" in capsys.readouterr().err


def test_a_contact_run_whose_only_radius_is_skipped_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["experiment", "cube", "--quick", "-q", "--protocol", "contact", "--no-cache", "--radii", "1e6",
                 "--methods", "pbd", "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "no contact radius fits the models" in err and "R = 1e+06 mm" in err and "smaller --radii" in err
    assert not out.exists()


def test_a_cut_bundle_is_refused_for_its_cut(tmp_path, capsys):
    solver = make_solver("pbd", HybridMesh.build(models.cube(resolution=300), fine_volume=False))
    scripted_incision(solver)
    bundle = solver.hybrid.save(tmp_path / "cut.npz")
    assert main(["experiment", str(bundle), "--quick", "-q", "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "was saved after" in err and "cutting moves" in err and "built without" not in err


@pytest.mark.parametrize("protocol", ["paper", "contact"])
def test_a_bad_later_model_file_is_refused_before_the_run(protocol, tmp_path, monkeypatch, capsys):
    from tissuesim.experiments import contact_protocol

    _no_run(monkeypatch)
    monkeypatch.setattr(contact_protocol, "run_contact", lambda *args, **kwargs: pytest.fail("the run started"))
    bad = tmp_path / "open.obj"
    bad.write_text("v 0 0 0\nv 0.05 0 0\nv 0 0.05 0\nf 1 2 3\n")        # one triangle: not a closed surface
    assert main(["experiment", "cube", str(bad), "--quick", "-q", "--protocol", protocol, "--no-cache",
                 "-o", str(tmp_path / "out")]) == 1
    assert str(bad) in capsys.readouterr().err.strip().splitlines()[-1]
