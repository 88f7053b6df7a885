"""Scene files a hostile or careless user writes are refused up front, in the file's own terms, with one line and
nothing built: arrays nested thousands deep, runs of too many steps, non-finite method options, a resolution out of
range, a folder named as the model file, files outside the scene's folder when confined, and files whose content a
message must not quote."""

import pytest

from tissuesim.cli import main
from tissuesim.mesh.models import cube
from tissuesim.scene import read_scene
from tissuesim.scene.load import SceneError


def _run(tmp_path, capsys, text, *arguments):
    """``tissuesim run`` of the scene ``text`` (written as scene.toml): its exit status and its stderr lines."""
    path = tmp_path / "scene.toml"
    path.write_text(text)
    status = main(["run", str(path), "--quiet", *arguments])
    return status, capsys.readouterr().err.strip().splitlines()


def _refused(tmp_path, capsys, text, *arguments) -> str:
    """The one line a refused scene prints (and that nothing was built: no mesh was announced)."""
    status, lines = _run(tmp_path, capsys, text, *arguments)
    assert status == 1 and len(lines) == 1, lines
    assert lines[0].startswith("tissuesim run: error: scene.toml")
    return lines[0]


def test_an_array_nested_thousands_deep_is_one_line_naming_the_file(tmp_path, capsys):
    line = _refused(tmp_path, capsys, '[model]\nname = "cube"\n[method.options]\nx = ' + "[" * 5000 + "]" * 5000)
    assert "nested" in line and "flatten" in line


def test_a_run_of_too_many_steps_is_refused_before_the_mesh_is_built(tmp_path, capsys):
    line = _refused(tmp_path, capsys, '[model]\nname = "cube"\n[run]\nduration = 1e12\ndt = 1e-9\n')
    assert "run.dt" in line and "1e+21 steps" in line and "at most 10000000" in line


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "[1.0, nan]", "{ a = { b = inf } }"])
def test_a_non_finite_method_option_is_refused_by_its_key(tmp_path, capsys, value):
    line = _refused(tmp_path, capsys, f'[model]\nname = "cube"\n[method]\nname = "pbd"\n'
                                      f'[method.options]\niterations = {value}\n')
    assert "method.options.iterations" in line and "not a finite number" in line


def test_a_resolution_out_of_range_names_the_key_not_a_flag(tmp_path, capsys):
    line = _refused(tmp_path, capsys, '[model]\nname = "cube"\nresolution = 10000000\n')
    assert "model.resolution" in line and "100000" in line and "--resolution" not in line


def test_a_folder_named_as_the_model_file_is_called_a_folder(tmp_path, capsys):
    (tmp_path / "meshes").mkdir()
    line = _refused(tmp_path, capsys, '[model]\nfile = "meshes"\n')
    assert "model.file" in line and "is a folder, not a file" in line


SECRET = "vmlinuz-secret-token\n"
FIXED_BY = '[model]\nname = "cube"\nresolution = 200\n[support.fixed]\nmask = "{}"\n'


def test_a_message_never_quotes_a_files_content(tmp_path, capsys):
    (tmp_path / "held.txt").write_text(SECRET)
    status, lines = _run(tmp_path, capsys, FIXED_BY.format("held.txt"))
    line = lines[-1]          # the file is parsed once the mesh it selects vertices of is built
    assert status == 1 and line.startswith("tissuesim run: error: scene.toml")
    assert "support.fixed" in line and "held.txt" in line and "vmlinuz" not in line and "secret" not in line


def test_files_outside_the_scenes_folder_are_read_by_default_and_refused_when_confined(tmp_path, capsys):
    inside = tmp_path / "scene"
    inside.mkdir()
    (tmp_path / "held.txt").write_text("1\n" * 10)
    text = FIXED_BY.format("../held.txt")
    (inside / "scene.toml").write_text(text)
    assert read_scene(inside / "scene.toml").scene.support.fixed.mask == "../held.txt"
    with pytest.raises(SceneError, match=r"support\.fixed\.mask: '\.\./held\.txt' lies outside the scene file's "
                                         r"folder"):
        read_scene(inside / "scene.toml", confine=True)
    line = _refused(inside, capsys, text, "--confine")
    assert "outside the scene file's folder" in line and "--confine" in line


def test_a_link_out_of_the_folder_is_outside_when_confined(tmp_path):
    (tmp_path / "scene").mkdir()
    (tmp_path / "scene" / "held.txt").symlink_to(tmp_path / "elsewhere.txt")
    (tmp_path / "elsewhere.txt").write_text("1\n")
    (tmp_path / "scene" / "scene.toml").write_text(FIXED_BY.format("held.txt"))
    with pytest.raises(SceneError, match="outside the scene file's folder"):
        read_scene(tmp_path / "scene" / "scene.toml", confine=True)


def test_a_mask_of_other_numbers_is_refused_without_quoting_them(tmp_path, capsys):
    (tmp_path / "held.txt").write_text("4194304\n" * cube(200).vertex_count)
    status, lines = _run(tmp_path, capsys, FIXED_BY.format("held.txt"))
    assert status == 1 and "neither 0 nor 1" in lines[-1] and "4194304" not in lines[-1]


@pytest.mark.parametrize("name, text", [("m.stl", "vmlinuz secret\n"), ("m.obj", "v 0 0 0\nv 1 vmlinuz 0\n"),
                                        ("m.obj", "v 0 0 0\nf 1 vmlinuz 2\n")])
def test_a_model_file_that_is_no_mesh_is_refused_without_quoting_it(tmp_path, capsys, name, text):
    (tmp_path / name).write_text(text)
    status, lines = _run(tmp_path, capsys, f'[model]\nfile = "{name}"\n')
    assert status == 1 and name in lines[-1] and "vmlinuz" not in lines[-1]
