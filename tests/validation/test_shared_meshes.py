"""The public organ meshes beside the repository: the clean ones are accepted, the two known bad ones are refused
with the right defect and repaired on request; the built-in models are valid."""

import numpy as np
import pytest
import trimesh

from tissuesim.errors import MeshError
from tissuesim.io import read_polygons, read_surface, surface_from_polygons
from tissuesim.mesh import models
from tissuesim.mesh.validate import self_intersections, validate_surface

CLEAN = [
    # file, scale to metres, vertices after merging, triangles
    ("sofa/liver2.obj", 0.01, 1170, 2336),
    ("sofa/liver.obj", 0.01, 139, 274),  # 181 vertices in the file, 42 of them unused copies
    ("softbodyliver/liver.obj", 0.01, 3001, 5998),
]


@pytest.mark.parametrize("name, scale, vertices, triangles", CLEAN)
def test_clean_organ_meshes_are_accepted(meshes_dir, name, scale, vertices, triangles):
    surface = read_surface(meshes_dir / name, scale=scale)
    assert (surface.vertex_count, surface.triangle_count) == (vertices, triangles)
    assert surface.signed_volume > 0
    # Organ-sized in metres: between 2 cm and 40 cm across.
    assert 0.02 < np.ptp(surface.vertices, axis=0).max() < 0.4


def test_liver_smooth_is_refused_for_self_intersections(meshes_dir):
    path = meshes_dir / "sofa/liver-smooth.obj"
    with pytest.raises(MeshError, match=r"7 self-intersecting triangle pairs \(first: \(810, 811\)") as info:
        read_surface(path, scale=0.01)
    message = str(info.value)
    assert "repair=True" in message and "boundary" not in message and "inward" not in message
    # The pairs involve 8 triangles around one fold of the surface.
    surface = read_surface(path, scale=0.01, repair=True)
    validate_surface(surface)
    assert surface.signed_volume > 0 and abs(surface.vertex_count - 2194) < 20


def test_liver_smooth_intersecting_triangles(meshes_dir):
    surface = surface_from_polygons(*read_polygons(meshes_dir / "sofa/liver-smooth.obj"))
    pairs = self_intersections(surface)
    assert np.unique(pairs).tolist() == [810, 811, 813, 1951, 1953, 1958, 1959, 4099]


def test_heart_is_refused_for_inward_faces_then_reversed(meshes_dir):
    path = meshes_dir / "sofa/coeur1_heart.obj"
    with pytest.raises(MeshError, match=r"faces point inward \(signed volume -1.387e-05 m³ < 0\)") as info:
        read_surface(path, scale=0.001)
    assert "self-intersect" not in str(info.value)
    surface = read_surface(path, scale=0.001, repair=True)
    # Against trimesh's own reading of the file (mm -> m): its vertex and face counts, and its signed volume, which
    # the repair must turn positive (rel 1e-9: the same divergence-theorem sum over the same triangles).
    other = trimesh.load(path, process=False)
    assert surface.vertex_count == len(other.vertices) and surface.triangle_count == len(other.faces)
    assert other.volume < 0.0
    assert surface.signed_volume == pytest.approx(-other.volume * 1e-9, rel=1e-9)


def test_built_in_models_are_valid(model_name):
    validate_surface(models.model(model_name))
