"""``--fix`` on the command line: bad text or an empty region is refused in one line before any cut, the region
given is the one held, and a model in the wrong unit is warned of in one line."""

import json

import meshio
import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.mesh.models import cube
from tissuesim.mesh.sizes import load_defaults


def _one_line(capsys, command: str) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"tissuesim {command}: error: "), err
    return err.strip()


def test_bad_fix_text_is_refused_before_any_model_is_built(tmp_path, capsys):
    for command in ("incise", "render"):
        assert main([command, "cube", "--fix", "plane:0,0,0.01", "-o", str(tmp_path / command)]) == 1
        assert "--fix 'plane:0,0,0.01' is not a region" in _one_line(capsys, command)
        assert not (tmp_path / command).exists()


def test_a_missing_mask_file_is_refused_before_any_model_is_built(tmp_path, capsys):
    assert main(["incise", "cube", "--fix", f"mask:{tmp_path / 'held.npy'}", "-o", str(tmp_path / "o")]) == 1
    assert "does not exist" in _one_line(capsys, "incise") and not (tmp_path / "o").exists()


def test_a_model_scaled_wrongly_is_warned_of_in_one_line_and_an_empty_box_refused(tmp_path, capsys):
    code = main(["incise", "cube", "--resolution", "300", "--scale", "100", "--fix", "box:1,1,1:2,2,2",
                 "-o", str(tmp_path / "o")])
    lines = capsys.readouterr().err.splitlines()
    assert code == 1 and len(lines) == 2, lines
    assert lines[0].startswith("tissuesim incise: warning: the built-in cube is 13.9 m across after scale 100")
    assert "--scale 1 (a file in m) would make it 13.9 cm across" in lines[0]
    assert lines[1].startswith("tissuesim incise: error: no node lies in the box")


def test_incise_holds_the_region_given_and_says_so(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["incise", "cube", "--resolution", "300", "--methods", "embedded", "--fix",
                 "plane:0,0,0.03:0,0,1", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "fixed: --fix plane:0,0,0.03:0,0,1 (" in err and "sized to a model 13.9 cm across" in err
    row, = json.loads((out / "incision.json").read_text())
    surface = cube(300)
    sized = load_defaults(surface.vertices, edge_length=surface.mean_edge_length)
    assert row["stroke_mm"] == pytest.approx(1e3 * sized.stroke, rel=1e-12) and 0 < row["pull_N"] <= sized.pull
    cut = meshio.read(out / "cube_embedded.vtu")
    moved = np.linalg.norm(cut.point_data["displacement"], axis=1)
    rest_height = cut.points[:, 2] - cut.point_data["displacement"][:, 2]
    assert moved.max() > 1e-5
    assert np.all(moved[rest_height <= 0.03 - 1e-9] == 0.0)     # the region behind the plane is held at rest
