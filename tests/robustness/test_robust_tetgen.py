"""Sweep item 14: building never changes the process's working directory and leaves no scratch folder behind."""

import os
import tempfile

import numpy as np
import pytest

from tissuesim import HybridMesh, MeshError
from tissuesim.mesh import models
from tissuesim.mesh.surface import SurfaceMesh
from tissuesim.mesh.tetrahedralize import tetrahedralize


@pytest.fixture
def watched(monkeypatch, tmp_path):
    """Record every os.chdir and make tmp_path the temporary directory."""
    calls = []
    real = os.chdir
    monkeypatch.setattr(os, "chdir", lambda path: (calls.append(path), real(path)))
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    return calls


def test_build_never_changes_the_working_directory(watched, tmp_path):
    HybridMesh.build(models.cube(resolution=100))
    assert watched == []
    assert not list(tmp_path.glob("tissuesim-tetgen-*"))


def test_a_failed_tetrahedralization_leaves_nothing_behind(watched, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    watched.clear()
    a, b = models.cube(100), models.cube(100)
    surface = SurfaceMesh(np.vstack([a.vertices, b.vertices + 0.02]), np.vstack([a.triangles, b.triangles + a.vertex_count]))
    with pytest.raises(MeshError):
        tetrahedralize(surface)
    assert watched == [] and list(tmp_path.iterdir()) == []
