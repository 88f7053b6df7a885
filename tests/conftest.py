"""Shared fixtures: the built-in models and the public organ meshes beside the repository."""

import os
from pathlib import Path

import pytest

from tissuesim.mesh import models

# The real meshes live outside the repository (see DESIGN data conventions); TISSUESIM_SHARED overrides the place.
SHARED = Path(os.environ.get("TISSUESIM_SHARED", Path(__file__).resolve().parents[1].parent / "shared"))
MESHES = SHARED / "data" / "meshes"


@pytest.fixture(scope="session")
def meshes_dir() -> Path:
    if not MESHES.is_dir():
        pytest.fail(f"shared organ meshes not found at {MESHES}; set TISSUESIM_SHARED to the shared folder")
    return MESHES


@pytest.fixture(scope="session", params=sorted(models.MODELS))
def model_name(request) -> str:
    return request.param
