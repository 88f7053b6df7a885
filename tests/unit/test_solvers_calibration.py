"""Calibration helpers: the case, the metric, and the frozen-value writer."""

import importlib.util
import math

import numpy as np
import pytest

from tissuesim import HybridMesh
from tissuesim.mesh import models
from tissuesim.solvers import calibrated
from tissuesim.experiments.calibration import CalibrationResult, calibration_case, evaluate, write_calibrated


@pytest.fixture(scope="module")
def small_cube():
    return HybridMesh.build(models.cube(resolution=200))


def test_case_loads_the_top_centre_and_metric_is_zero_for_the_reference(small_cube):
    node, samples, reference = calibration_case(small_cube)
    v = small_cube.surface.vertices
    assert v[node, 2] == v[:, 2].max() and samples[0] == node and len(samples) == 50
    assert reference[node, 2] < v[node, 2]  # pressure pushes it down
    # The reference is the refined (quadratic) FEM, so the default fine volume is near it but not on it: on this
    # 200-vertex cube its linear tets are off by 0.51 of the reference's RMS.
    reference_rms = np.sqrt(np.mean(np.sum((reference[samples] - v[samples]) ** 2, axis=1)))
    assert 0.0 < evaluate("fem", small_cube, (node, samples, reference)) < 0.6 * reference_rms
    error = evaluate("hybrid", small_cube, (node, samples, reference))
    assert 0.0 < error < math.inf


def test_write_calibrated_round_trips(tmp_path):
    result = CalibrationResult("hybrid", "pbd", "stiffness", 0.4321, 1e-3, 2e-3, 7, 1.0)
    path = write_calibrated([result], tmp_path / "calibrated.py")
    spec = importlib.util.spec_from_file_location("written", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.value("hybrid", "pbd") == 0.4321  # exact: written as repr
    assert module.CALIBRATED["hybrid"]["pbd"][2:] == (1e-3, 2e-3)
    assert module.MASS_SPRING_THICKNESS == calibrated.MASS_SPRING_THICKNESS
    assert np.isnan(module.CALIBRATED["hybrid"]["xpbd"][2]) == np.isnan(calibrated.CALIBRATED["hybrid"]["xpbd"][2])


def test_calibrate_command_prints_the_value_and_rmse(small_cube, tmp_path, capsys):
    from tissuesim.cli import main

    bundle = tmp_path / "cube.npz"
    small_cube.save(bundle)
    assert main(["calibrate", "--bundle", str(bundle), "--method", "hybrid", "--form", "pbd"]) == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith("hybrid") and "stiffness =" in line and "RMSE" in line
    value = float(line.split("stiffness =")[1].split()[0])
    assert 1e-3 <= value <= 1.0


def test_calibrate_command_refuses_a_method_without_free_scalar(capsys):
    from tissuesim.cli import main

    assert main(["calibrate", "--method", "fem"]) == 1
    assert "cannot calibrate fem" in capsys.readouterr().err
