import numpy as np
import pytest
import trimesh

from tissuesim.errors import MeshError
from tissuesim.mesh import models


def test_default_models_are_closed_outward_and_table1_sized(model_name):
    surface = models.model(model_name)
    mesh = trimesh.Trimesh(surface.vertices, surface.triangles, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert surface.signed_volume > 0
    assert 1300 <= surface.vertex_count <= 1550
    assert surface.bounds[0, 2] == 0.0  # rests on z = 0 (exact: the lowest z minus itself)
    assert np.allclose(surface.bounds[0, :2], -surface.bounds[1, :2])
    assert surface.triangle_areas.min() > 0


def test_models_are_deterministic(model_name):
    a, b = models.model(model_name), models.model(model_name)
    # determinism: bit for bit
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)


@pytest.mark.parametrize("name", ["sphere", "liver", "steak"])
def test_resolution_sets_vertex_count(name):
    assert models.model(name, 300).vertex_count == 300


def test_cube_resolution_picks_nearest_grid():
    assert models.cube(600).vertex_count == 6 * 10**2 + 2  # 11 points per edge: 602 is the nearest 6 (k-1)² + 2


def test_anatomical_sizes():
    assert np.allclose(np.ptp(models.cube().vertices, axis=0), models.CUBE_EDGE)
    assert np.allclose(np.ptp(models.sphere().vertices, axis=0), 2 * models.SPHERE_RADIUS, rtol=0.01)
    liver = np.ptp(models.liver().vertices, axis=0)
    assert 0.15 < liver[0] < 0.25 and liver[2] < liver[1] < liver[0]
    steak = np.ptp(models.steak().vertices, axis=0)
    assert steak[2] < 0.2 * steak[0]  # flat


@pytest.mark.parametrize("bad", [10, 0, 99.5])
def test_bad_resolution_is_a_clear_error(bad):
    with pytest.raises(MeshError, match="resolution"):
        models.sphere(bad)


def test_unknown_model_names_the_choices():
    with pytest.raises(MeshError, match="cube, sphere, liver, steak"):
        models.model("kidney")
