"""Smaller CLI and API inconsistencies: built-in names win over a same-named folder, --scale means the same in every
command, a bundle's bad --scale is refused, material and build options refuse what they cannot mean, a device is
said to be no bundle."""

import math

import numpy as np
import pytest

from tissuesim import BundleError, HybridMesh, MaterialError, MeshError
from tissuesim.cli import main
from tissuesim.experiments.sweep_config import ExperimentConfig, load_model
from tissuesim.fem.material import Material
from tissuesim.mesh import models


@pytest.mark.parametrize("command", [["build", "--no-fine-volume"], ["incise", "--methods", "pbd"]])
def test_a_folder_named_like_a_built_in_does_not_hide_it(command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cube").mkdir()
    assert main([command[0], "cube", *command[1:], "--resolution", "300", "-o", "out.npz"
                 if command[0] == "build" else "out"]) == 0, capsys.readouterr().err


def test_scale_applies_to_a_built_in_in_the_experiments_as_in_build(capsys):
    config = ExperimentConfig(models=("cube",), resolution=300, scale=0.5)
    hybrid = load_model("cube", config)
    edge = float(np.ptp(hybrid.surface.vertices[:, 0]))
    assert edge == pytest.approx(0.5 * models.CUBE_EDGE, rel=1e-12)   # one product per coordinate: round-off only


def test_a_bundles_bad_scale_is_refused_not_ignored(tmp_path, capsys):
    bundle = HybridMesh.build(models.cube(resolution=300), fine_volume=False).save(tmp_path / "b.npz")
    assert main(["incise", str(bundle), "--scale", "0", "--methods", "pbd", "-o", str(tmp_path / "out")]) == 1
    assert "scale must be a positive finite number" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_a_poisson_ratio_of_minus_one_names_its_own_bound():
    with pytest.raises(MaterialError) as caught:
        Material(poisson_ratio=-1)
    assert "lambda infinite" not in str(caught.value) and "-1 makes the bulk modulus zero" in str(caught.value)


@pytest.mark.parametrize("name", ["youngs_modulus", "poisson_ratio"])
def test_a_bool_is_no_material_constant(name):
    with pytest.raises(MaterialError, match=f"{name} must be a real number, got the bool True"):
        Material(**{name: True})


@pytest.mark.parametrize("target", [math.nan, 2.5, "100", True])
def test_a_target_vertex_count_that_is_no_whole_number_is_a_mesh_error(target):
    with pytest.raises(MeshError, match="target_vertices must be a whole number"):
        HybridMesh.build(models.cube(resolution=300), target_vertices=target, fine_volume=False)


def test_a_device_is_no_bundle():
    with pytest.raises(BundleError, match="/dev/null is not a regular file"):
        HybridMesh.load("/dev/null")
