"""Fixtures of the hostile-input sweep: small models, built once per session, so the sweep stays fast."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from tissuesim import HybridMesh
from tissuesim.experiments.protocol import load_node
from tissuesim.mesh import models


@pytest.fixture(scope="session")
def small_cube():
    """A cube of 386 surface vertices with its fine volume."""
    return HybridMesh.build(models.cube(resolution=386))


@pytest.fixture(scope="session")
def small_cube_top(small_cube):
    """The load node of the protocol: the top node on the vertical centre axis."""
    s = small_cube.surface
    return load_node(s.vertices, s.triangles)


@pytest.fixture(scope="session")
def small_cube_size(small_cube):
    """The cube's size: the diagonal of its bounding box [m]."""
    v = small_cube.surface.vertices
    return float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))


@pytest.fixture(scope="session")
def synthetic_results():
    """``synthetic_results(models=..., forces=...)``: a valid results document, from the unit tests of the outputs."""
    path = Path(__file__).resolve().parents[1] / "unit" / "test_experiments_outputs.py"
    spec = importlib.util.spec_from_file_location("experiment_outputs_tests", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.synthetic_results
