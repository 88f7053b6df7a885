"""Messages a user can act on: each names the defect, where it is and what to do, in the user's own terms, and comes
before any work."""

import tempfile
from pathlib import Path

import numpy as np
import pytest

import tissuesim
from tissuesim import BundleError, HybridMesh, MaterialError, MeshError
from tissuesim.cli import main
from tissuesim.fem.material import Material
from tissuesim.mesh import models

# a regular tetrahedron-like surface 1 cm across: valid, but far smaller than the 3 cm scripted incision
TET_OBJ = "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nv 0 0 0.01\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


@pytest.fixture
def tet(tmp_path):
    path = tmp_path / "tet.obj"
    path.write_text(TET_OBJ)
    return path


def _one_line_error(capsys, command: str) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"tissuesim {command}: error: "), err
    return err.strip()


# -- build -o: the target is checked before the build, and named ----------------------------------------------


def test_build_to_an_empty_path_is_refused_before_the_build(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["build", "cube", "--resolution", "200", "--no-fine-volume", "-o", ""]) == 1
    err = capsys.readouterr().err
    assert "reading cube" not in err                        # nothing was built
    assert err.strip() == ("tissuesim build: error: the bundle path is empty; give the path of a .npz file, e.g. "
                           "--output cube.npz")
    assert list(tmp_path.iterdir()) == []


def _unwritable(monkeypatch, folder: Path):
    """Make ``folder`` refuse new files, as a read-only folder does for a user who is not root."""
    real = tempfile.mkstemp

    def refuse(*args, dir=None, **kwargs):
        if dir is not None and Path(dir) == folder:
            raise PermissionError(13, "Permission denied", str(Path(dir) / "tmpname"))
        return real(*args, dir=dir, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", refuse)


def test_build_into_an_unwritable_folder_is_refused_before_the_build_naming_the_bundle(tmp_path, monkeypatch,
                                                                                        capsys):
    _unwritable(monkeypatch, tmp_path)
    target = tmp_path / "cube.npz"
    assert main(["build", "cube", "--resolution", "200", "--no-fine-volume", "-o", str(target)]) == 1
    err = capsys.readouterr().err
    assert "reading cube" not in err
    assert err.strip() == (f"tissuesim build: error: cannot save the bundle to {target}: Permission denied in "
                           f"{tmp_path}; choose another path or make that folder writable")


def test_save_names_the_bundle_not_its_temporary_file(tmp_path, monkeypatch):
    hybrid = HybridMesh.build(models.cube(resolution=200), fine_volume=False)
    _unwritable(monkeypatch, tmp_path)
    with pytest.raises(BundleError, match=r"cannot save the bundle to .*cube\.npz: Permission denied") as error:
        hybrid.save(tmp_path / "cube.npz")
    assert "tmpname" not in str(error.value) and list(tmp_path.iterdir()) == []


# -- incise: a model the incision does not fit --------------------------------------------------------------------


def test_incise_on_a_model_smaller_than_the_incision_says_so(tet, tmp_path, capsys):
    assert main(["incise", str(tet), "--methods", "pbd", "--output", str(tmp_path / "out")]) == 1
    err = _one_line_error(capsys, "incise")
    # the stroke is sized to the model (mesh.sizes), so what stops it is the tet's pointed top
    assert "incision does not fit tet: the model is 1 cm long along x, but its top is not flat there" in err
    assert "pass a larger depth" not in err
    assert not (tmp_path / "out").exists()


# -- the library's own entry points -------------------------------------------------------------------------------


def test_loading_a_surface_file_as_a_bundle_says_it_is_not_one_and_never_suggests_pickle(tet, tmp_path):
    objects = tmp_path / "objects.npz"
    np.savez(objects, header=np.array([{"format": "tissuesim-hybrid"}], dtype=object))
    for path in (tet, objects):
        with pytest.raises(BundleError) as error:
            HybridMesh.load(path)
        message = str(error.value)
        assert f"{path} is not a readable hybrid-mesh bundle" in message, message
        assert "tissuesim build MESH --output FILE.npz" in message
        assert "pickle" not in message.replace("Python objects", "")


def test_loading_a_folder_as_a_bundle_is_a_bundle_error(tmp_path):
    with pytest.raises(BundleError, match=f"{tmp_path} is a folder, not a hybrid-mesh bundle"):
        HybridMesh.load(tmp_path)


@pytest.mark.parametrize("path", [None, 3])
def test_a_bundle_path_that_is_not_a_path_is_a_bundle_error(path):
    with pytest.raises(BundleError, match=f"a bundle path must be a str or pathlib.Path, got {type(path).__name__}"):
        HybridMesh.load(path)


@pytest.mark.parametrize("surface, words", [
    (None, "HybridMesh.build takes a SurfaceMesh, got NoneType None; read a surface file with "
           "tissuesim.read_surface"),
    ("cube", "HybridMesh.build takes a SurfaceMesh, got str 'cube'; for the built-in model use "
             "tissuesim.models.cube()"),
])
def test_build_of_something_that_is_not_a_surface_is_a_mesh_error(surface, words):
    with pytest.raises(MeshError) as error:
        HybridMesh.build(surface)
    assert str(error.value).startswith(words)


@pytest.mark.parametrize("path", [None, 3, ""])
def test_read_surface_of_something_that_is_not_a_path_is_a_mesh_error(path):
    with pytest.raises(MeshError, match="read_surface needs the path of a surface file"):
        tissuesim.read_surface(path)


# -- values printed as given ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("nu", [0.4999999, 0.4900001])
def test_a_poisson_ratio_just_above_the_limit_is_printed_as_given(nu):
    with pytest.raises(MaterialError) as error:
        Material(5500.0, nu)
    assert str(error.value).startswith(f"poisson_ratio {nu!r} is above 0.49")


def test_render_radius_is_reported_in_millimetres_as_typed(tmp_path, capsys):
    assert main(["render", "cube", "--resolution", "300", "--radius", "-4", "--output", str(tmp_path / "o")]) == 1
    err = _one_line_error(capsys, "render")
    assert err.endswith("--radius must be a positive finite number [mm], got -4.0")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("force", ["0", "-5", "nan"])
def test_render_force_zero_is_refused_not_replaced_by_the_default(force, tmp_path, capsys):
    assert main(["render", "cube", "--resolution", "300", "--force", force, "--output", str(tmp_path / "o")]) == 1
    err = _one_line_error(capsys, "render")
    assert err.endswith(f"--force must be a positive finite number [N], got {float(force)!r}")
    assert not (tmp_path / "o").exists()
