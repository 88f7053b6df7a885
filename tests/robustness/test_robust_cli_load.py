"""``tissuesim incise`` reads what the other commands read (bundles included) and checks every argument before the
first cut."""

import json

import pytest

from tissuesim import HybridMesh
from tissuesim.cli import main
from tissuesim.mesh import models


def test_incise_cuts_a_saved_bundle(tmp_path):
    bundle = HybridMesh.build(models.cube(resolution=300), fine_volume=False).save(tmp_path / "small cube.npz")
    out = tmp_path / "cut"
    assert main(["incise", str(bundle), "--methods", "pbd", "--output", str(out)]) == 0
    rows = json.loads((out / "incision.json").read_text())
    assert [(r["model"], r["method"]) for r in rows] == [("small cube", "pbd")]
    assert rows[0]["vertices_added"] > 0 and rows[0]["invariants"] == []
    assert (out / "small cube_pbd.obj").is_file()


@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if any hybrid mesh is built or any solver made: the refusal must come first."""
    def forbidden(*args, **kwargs):
        raise AssertionError("work started before every argument was checked")

    monkeypatch.setattr(HybridMesh, "build", forbidden)
    monkeypatch.setattr("tissuesim.solvers.make_solver", forbidden)


@pytest.mark.parametrize("arguments, message", [
    (["cube", "no-such-model"], "'no-such-model' is neither a built-in model"),
    (["cube", "missing.obj"], "surface file not found: missing.obj"),
    (["cube", "--scale", "0"], "scale must be a positive finite number"),
    (["cube", "--methods", "pbd", "scissors"], "unknown method 'scissors'"),
    (["cube", "--prestrain", "-0.1"], "prestrain must lie in [0, 0.3]"),
])
def test_a_bad_argument_is_refused_before_any_model_is_built(arguments, message, tmp_path, monkeypatch, capsys,
                                                              no_work):
    monkeypatch.chdir(tmp_path)
    assert main(["incise", *arguments, "--output", "out"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("tissuesim incise: error: ") and err.count("\n") == 1, err
    assert message in err
    assert list(tmp_path.iterdir()) == []


def test_a_bad_output_is_refused_before_any_model_is_built(tmp_path, capsys, no_work):
    target = tmp_path / "taken"
    target.write_text("a file")
    assert main(["incise", "cube", "--output", str(target)]) == 1
    assert "is a file, not a folder" in capsys.readouterr().err
    assert target.read_text() == "a file"
