"""Advice a command-line user can follow: --repair where the message offers it, a model too small or coarse for a
command's load said in those terms (not PinHead.grab or `fixed`), the true cause of an incision that does not fit,
and no call to reset() after a run that blew up."""

import json

import pytest

from tissuesim import write_surface
from tissuesim.cli import main
from tissuesim.mesh import models
from tissuesim.viewer.gl import opengl_available

needs_opengl = pytest.mark.skipif(not opengl_available(), reason="no OpenGL: render stops before reading a model")

# a tetrahedron 1 cm across: valid, but smaller than any command's load region
TET_OBJ = "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nv 0 0 0.01\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
# Python-level advice a command-line user cannot follow
API_TERMS = ("PinHead", "`fixed`", "reset()", "repair=True")


@pytest.fixture
def tet(tmp_path):
    path = tmp_path / "tet.obj"
    path.write_text(TET_OBJ)
    return path


def _last_error(capsys, command):
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"tissuesim {command}: error: ") and not any("Traceback" in line for line in err)
    assert not any(term in err[-1] for term in API_TERMS), err[-1]
    return err[-1]


@pytest.mark.parametrize("command", [["incise", "--methods", "pbd"], pytest.param(["render"], marks=needs_opengl)])
def test_the_repair_a_message_offers_is_an_option_of_the_command(command, tmp_path, capsys):
    surface = models.cube(resolution=300)
    inward = tmp_path / "inward.obj"
    write_surface(inward, surface.__class__(surface.vertices, surface.triangles[:, ::-1]))
    assert main([command[0], str(inward), *command[1:], "-o", str(tmp_path / "out")]) == 1
    assert "--repair" in capsys.readouterr().err
    assert main([command[0], str(inward), *command[1:], "--repair", "-o", str(tmp_path / "out")]) == 0, \
        capsys.readouterr().err


@pytest.mark.parametrize("command", [["experiment", "--quick", "-q"], pytest.param(["render"], marks=needs_opengl)])
def test_a_model_too_small_for_the_load_is_said_in_command_line_terms(command, tet, tmp_path, capsys):
    assert main([command[0], str(tet), *command[1:], "-o", str(tmp_path / "out")]) == 1
    err = _last_error(capsys, command[0])
    assert "tet is too small or too coarse for" in err and "--scale" in err


def test_a_coarse_built_in_is_cut_by_a_stroke_and_pull_sized_to_its_edges(tmp_path):
    # the fixed 3 cm stroke and 5 mm offset put this sphere's pull on its support; sized ones (mesh.sizes) cut it
    assert main(["incise", "sphere", "--resolution", "50", "--methods", "pbd", "-o", str(tmp_path / "out")]) == 0
    row, = json.loads((tmp_path / "out" / "incision.json").read_text())
    assert row["vertices_added"] > 0 and row["invariants"] == []


def test_an_incision_on_a_pointed_top_names_the_top_not_the_length(tet, tmp_path, capsys):
    assert main(["incise", str(tet), "--scale", "10", "--methods", "pbd", "-o", str(tmp_path / "out")]) == 1
    err = _last_error(capsys, "incise")
    assert "the model is 10 cm long along x, but its top is not flat there" in err
    assert "longer" not in err


def test_a_run_that_blows_up_gives_command_line_advice(tmp_path, capsys):
    assert main(["experiment", "cube", "--quick", "-q", "--resolution", "300", "--forces", "1e100", "--methods",
                 "pbd", "-o", str(tmp_path / "out")]) == 1
    err = _last_error(capsys, "experiment")
    assert err.startswith("tissuesim experiment: error: cube: pbd cannot carry tension 1e+100 N: ")
    assert err.endswith("give smaller --forces (the run stops here, nothing is written)")
    assert not (tmp_path / "out").exists()
