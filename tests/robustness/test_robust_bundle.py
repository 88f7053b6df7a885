"""Sweep item 6: a damaged bundle is refused at load with a BundleError naming the array, never later."""

import json

import numpy as np
import pytest

from tissuesim import BundleError, HybridMesh, cli


@pytest.fixture(scope="module")
def saved(small_cube, tmp_path_factory):
    path = small_cube.save(tmp_path_factory.mktemp("bundle") / "cube.npz")
    with np.load(path) as data:
        arrays = {key: data[key] for key in data.files}
    return arrays


def damaged(arrays, tmp_path, **changes):
    """A copy of the bundle's arrays with ``changes`` (None deletes), saved to a file."""
    arrays = dict(arrays)
    header = json.loads(arrays["header"].tobytes())
    for key, value in changes.pop("header", {}).items():
        if value is None:
            header.pop(key)
        else:
            header[key] = value
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    arrays.update(changes)
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    return path


def shifted(array, value):
    array = array.copy()
    array[3] = value
    return array


@pytest.mark.parametrize("change, named", [
    (lambda a: {"embedding_tet": shifted(a["embedding_tet"], len(a["volume_tets"]))}, "embedding_tet"),
    (lambda a: {"coarse_triangle": shifted(a["coarse_triangle"], len(a["coarse_triangles"]) + 5)}, "coarse_triangle"),
    (lambda a: {"control_volume": shifted(a["control_volume"], len(a["volume_points"]))}, "control_volume"),
    (lambda a: {"control_volume": a["control_volume"][::-1].copy()}, r"volume_points\[control_volume\]"),
    (lambda a: {"control": np.random.default_rng(0).permutation(a["control"])}, "control"),
    (lambda a: {"coarse_barycentric": shifted(a["coarse_barycentric"], np.nan)}, "coarse_barycentric"),
    (lambda a: {"embedding_barycentric": shifted(a["embedding_barycentric"], 0.25)}, "embedding_barycentric"),
    (lambda a: {"embedding_tet": a["embedding_tet"].astype(np.float64)}, "embedding_tet has dtype float64"),
    (lambda a: {"fine_surface_nodes": a["fine_surface_nodes"][::-1].copy()}, r"fine_points\[fine_surface_nodes\]"),
    (lambda a: {"header": {"format_version": "1"}}, "format_version is '1'"),
    (lambda a: {"header": {"has_fine_volume": None}}, "has_fine_volume"),
], ids=["embedding_tet", "coarse_triangle", "control_volume", "control_volume_order", "shuffled_control",
        "nan_barycentric", "embedding_weights", "float_indices", "fine_nodes", "version_string", "no_fine_flag"])
def test_damaged_bundle_is_refused_naming_the_array(saved, tmp_path, change, named):
    with pytest.raises(BundleError, match=named):
        HybridMesh.load(damaged(saved, tmp_path, **change(saved)))


def test_the_experiment_command_refuses_a_damaged_bundle_in_one_line(saved, tmp_path, capsys):
    path = damaged(saved, tmp_path, embedding_tet=shifted(saved["embedding_tet"], 10**6))
    assert cli.main(["experiment", str(path), "--quick", "--quiet", "-o", str(tmp_path / "out")]) == 1
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "embedding_tet" in error[0]

