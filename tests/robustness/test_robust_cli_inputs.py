"""CLI inputs against outputs: build -o never replaces its input surface, two models of one name are refused up
front by every command that writes per-model files, a long -o name is not refused for its probe file's name."""

import pytest

from tissuesim import write_surface
from tissuesim.cli import main
from tissuesim.mesh import models


@pytest.fixture
def victim(tmp_path):
    path = tmp_path / "data" / "victim.obj"
    path.parent.mkdir()
    write_surface(path, models.cube(resolution=300))
    return path


@pytest.mark.parametrize("through_link", [False, True])
def test_build_refuses_to_save_over_its_input(victim, through_link, capsys):
    source = victim
    if through_link:
        source = victim.with_name("link.obj")
        source.symlink_to(victim.name)
    before = victim.read_bytes()
    assert main(["build", str(source), "--no-fine-volume", "-o", str(victim)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith(f"tissuesim build: error: -o {victim} is the input surface") and len(err) == 1
    assert victim.read_bytes() == before                         # still the OBJ, not a zip


@pytest.mark.parametrize("command", [["incise", "--methods", "pbd"], ["render", "--if-available"],
                                     ["experiment", "--quick", "--quiet"]])
def test_two_models_of_one_name_are_refused_before_any_work(command, victim, tmp_path, capsys):
    twin = victim.with_name("cube.obj")
    victim.rename(twin)
    out = tmp_path / "out"
    assert main([command[0], "cube", str(twin), *command[1:], "--resolution", "300", "-o", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"tissuesim {command[0]}: error: models 'cube' and {str(twin)!r} are both named 'cube', so their "
                   "results and files would overwrite each other; give each model once, or copy a file under another "
                   "name"]
    assert not out.exists()


def test_a_long_output_name_is_not_refused_for_a_temporary_files_name(tmp_path, capsys):
    target = tmp_path / ("b" * 240 + ".npz")                     # 244 bytes: a valid name, its probe's was not
    assert main(["build", "cube", "--resolution", "300", "--no-fine-volume", "-o", str(target)]) == 0, \
        capsys.readouterr().err
    assert target.is_file()
