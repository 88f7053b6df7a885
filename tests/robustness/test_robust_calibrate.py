"""Sweep item 13: ``tissuesim calibrate`` refuses bad options and says what it calibrates on."""

import pytest

from tissuesim import HybridMesh, cli
from tissuesim.mesh import models


@pytest.mark.parametrize("arguments, message", [
    (["--form", "bogus", "--method", "pbd"], "unknown --form bogus"),
    (["--method", "mass-spring", "--form", "xpbd"], "unknown --form xpbd"),
])
def test_bad_options_are_refused_before_any_work(arguments, message, capsys):
    assert cli.main(["calibrate", *arguments]) == 1
    err = capsys.readouterr().err
    assert message in err and "building" not in err


def test_a_bundle_of_another_model_is_not_frozen_as_the_cubes_values(tmp_path, capsys):
    path = HybridMesh.build(models.sphere(resolution=200), fine_volume=False).save(tmp_path / "sphere.npz")
    assert cli.main(["calibrate", "--bundle", str(path), "--method", "mass-spring", "--write"]) == 1
    assert "is not the built-in cube" in capsys.readouterr().err


def test_the_calibration_model_is_named(tmp_path, capsys, monkeypatch):
    path = HybridMesh.build(models.sphere(resolution=200)).save(tmp_path / "sphere.npz")

    def stop(*args, **kwargs):
        raise KeyboardInterrupt     # the notice comes before any calibration run

    monkeypatch.setattr("tissuesim.experiments.calibration.calibrate", stop)
    monkeypatch.setattr("tissuesim.experiments.calibration.calibration_case", stop)
    assert cli.main(["calibrate", "--bundle", str(path), "--method", "mass-spring"]) == 130
    assert "calibrating on " + str(path) + ", NOT the built-in cube" in capsys.readouterr().err
