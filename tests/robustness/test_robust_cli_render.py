"""``tissuesim render``: a bad --report is refused before any drawing, files are written whole, links survive
spaces, and a method that cannot be cut skips its incision figure in one line."""

import re
import tempfile
from pathlib import Path

import matplotlib.figure
import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.commands.render import link_figures
from tissuesim.viewer.figures import compose
from tissuesim.viewer.gl import opengl_available

needs_opengl = pytest.mark.skipif(not opengl_available(), reason="no OpenGL (install libegl1 libegl-mesa0 "
                                                                 "libgl1-mesa-dri)")
# CommonMark's image link: a destination is either <...> (backslash escapes inside) or a run without spaces
IMAGE_LINK = re.compile(r"!\[[^\]]*\]\((<(?:[^<>\\\n]|\\.)*>|[^\s<>()]+)\)")


def _destinations(markdown: str) -> list[str]:
    found = []
    for destination in IMAGE_LINK.findall(markdown):
        if destination.startswith("<"):
            destination = re.sub(r"\\(.)", r"\1", destination[1:-1])
        found.append(destination)
    return found


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("tissuesim render: error: "), err
    return err.strip()


def test_a_report_that_is_a_folder_is_refused_before_any_drawing(tmp_path, capsys):
    out = tmp_path / "figures"
    assert main(["render", "cube", "--resolution", "300", "--output", str(out), "--report", str(tmp_path)]) == 1
    err = _one_line_error(capsys)
    assert f"--report {tmp_path} is a folder" in err and "report.md" in err
    assert not out.exists()


def test_a_report_in_an_unwritable_folder_is_refused_before_any_drawing(tmp_path, monkeypatch, capsys):
    folder = tmp_path / "docs"
    folder.mkdir()
    real = tempfile.mkstemp

    def refuse(*args, dir=None, **kwargs):  # a read-only folder, for a user who is not root
        if dir is not None and Path(dir) == folder:
            raise PermissionError(13, "Permission denied")
        return real(*args, dir=dir, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    out = tmp_path / "figures"
    report = folder / "report.md"
    assert main(["render", "cube", "--resolution", "300", "--output", str(out), "--report", str(report)]) == 1
    assert _one_line_error(capsys).endswith(f"cannot write --report {report}: Permission denied in {folder}; "
                                            "choose another path or make that folder writable")
    assert not out.exists() and list(folder.iterdir()) == []


def test_a_report_that_is_not_text_is_refused_before_any_drawing(tmp_path, capsys):
    report = tmp_path / "report.md"
    report.write_bytes(b"\xff\xfe\x00 not utf-8")
    assert main(["render", "cube", "--resolution", "300", "--output", str(tmp_path / "o"), "--report",
                 str(report)]) == 1
    assert f"cannot read --report {report}" in _one_line_error(capsys)
    assert report.read_bytes() == b"\xff\xfe\x00 not utf-8" and not (tmp_path / "o").exists()


def test_an_interrupted_figure_leaves_the_earlier_png_and_no_partial_file(tmp_path, monkeypatch):
    target = tmp_path / "deformation_cube.png"
    target.write_bytes(b"the earlier figure")
    real = matplotlib.figure.Figure.savefig

    def interrupted(self, fname, **kwargs):
        Path(fname).write_bytes(b"\x89PNG half")     # what a killed save leaves behind
        raise KeyboardInterrupt

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", interrupted)
    with pytest.raises(KeyboardInterrupt):
        compose([np.zeros((8, 8, 3), np.uint8)], ["panel"], "title", 1.0, target)
    assert target.read_bytes() == b"the earlier figure"
    assert [p.name for p in tmp_path.iterdir()] == [target.name]
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", real)
    compose([np.zeros((8, 8, 3), np.uint8)], ["panel"], "title", 1.0, target)
    assert target.read_bytes().startswith(b"\x89PNG") and [p.name for p in tmp_path.iterdir()] == [target.name]


def test_report_links_resolve_on_paths_with_spaces(tmp_path):
    folder = tmp_path / "my results"
    figures = [folder / "figs (2026)" / "deformation_cube.png", tmp_path / "other place" / "incision_cube.png"]
    for figure in figures:
        figure.parent.mkdir(parents=True)
        figure.write_bytes(b"png")
    report = folder / "report.md"
    report.write_text("# Report\n")
    link_figures(report, figures)
    destinations = _destinations(report.read_text())
    assert destinations == ["figs (2026)/deformation_cube.png", "../other place/incision_cube.png"]
    assert all((report.parent / d).resolve() == f.resolve() for d, f in zip(destinations, figures))


def test_a_plain_path_keeps_a_plain_link(tmp_path):
    figure = tmp_path / "deformation_cube.png"
    link_figures(tmp_path / "report.md", [figure])
    assert "![deformation_cube](deformation_cube.png)" in (tmp_path / "report.md").read_text()


@needs_opengl
def test_render_fem_skips_the_incision_figure_in_one_line(tmp_path, capsys):
    assert main(["render", "cube", "--resolution", "300", "--method", "fem", "--output", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    skipped = [line for line in err.splitlines() if "incision figures skipped" in line]
    assert len(skipped) == 1 and "the fem reference cannot be cut" in skipped[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deformation_cube.png"]


def test_a_missing_second_model_is_refused_before_the_first_is_drawn(tmp_path, capsys):
    out = tmp_path / "figures"
    assert main(["render", "cube", "no-such-model", "--resolution", "300", "--output", str(out)]) == 1
    assert "model 'no-such-model' is neither a built-in model" in _one_line_error(capsys)
    assert not out.exists()


def test_an_empty_output_is_refused_not_taken_as_the_current_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["render", "cube", "--resolution", "300", "--output", ""]) == 1
    assert "output path is empty" in _one_line_error(capsys)
    assert list(tmp_path.iterdir()) == []


@needs_opengl
def test_render_says_the_region_held_and_the_sized_loads_and_uses_a_given_force_as_given(tmp_path, capsys):
    out = tmp_path / "figures"
    assert main(["render", "cube", "--resolution", "300", "--fix", "plane:0,0,0.02:0,0,1", "--force", "0.2",
                 "--output", str(out)]) == 0
    said = [line for line in capsys.readouterr().err.splitlines() if line.startswith("tissuesim render: cube: ")]
    assert len(said) == 1, said
    assert "fixed: --fix plane:0,0,0.02:0,0,1 (" in said[0] and "0.2 N over a" in said[0]
    assert "sized to a model 13.9 cm across" in said[0] and "(--force as given)" in said[0]
    assert sorted(p.name for p in out.iterdir()) == ["deformation_cube.png", "incision_cube.png"]


@needs_opengl
def test_render_refuses_a_region_that_holds_the_load_node_before_drawing(tmp_path, capsys):
    out = tmp_path / "figures"
    assert main(["render", "cube", "--resolution", "300", "--fix", "plane:0,0,0.079:0,0,-1",
                 "--output", str(out)]) == 1
    err = _one_line_error(capsys)
    assert "the figure's load at its top centre on cube falls on node" in err
    assert err.endswith("choose a --fix region that leaves it free")
    assert not out.exists()
