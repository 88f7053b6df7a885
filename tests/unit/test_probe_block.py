"""The indentation block (tissuesim.mesh.models.indentation_block): a closed box whose top is graded fine about its
centre, for contact tests such as Hertz's."""

import numpy as np
import pytest
import trimesh

from tissuesim.errors import MeshError
from tissuesim.mesh import models
from tissuesim.mesh.validate import validate_surface


def edge_lengths_near(surface, radius_lo, radius_hi):
    v = surface.vertices
    edges = surface.edges
    middle = 0.5 * (v[edges[:, 0]] + v[edges[:, 1]])
    on_top = np.all(v[edges][:, :, 2] == v[:, 2].max(), axis=1)
    r = np.linalg.norm(middle[:, :2], axis=1)
    chosen = on_top & (r >= radius_lo) & (r < radius_hi)
    return np.linalg.norm(v[edges[chosen, 0]] - v[edges[chosen, 1]], axis=1)


def test_the_block_is_a_closed_outward_box_of_the_asked_size():
    surface = models.indentation_block()
    validate_surface(surface)                       # closed, manifold, oriented, no self-intersection
    mesh = trimesh.Trimesh(surface.vertices, surface.triangles, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert np.isclose(surface.signed_volume, 0.08 * 0.08 * 0.04, rtol=1e-12)   # exact: a box of flat faces
    assert np.allclose(surface.bounds, [[-0.04, -0.04, 0.0], [0.04, 0.04, 0.04]], atol=1e-15)


def test_the_top_is_fine_at_its_centre_and_coarse_far_from_it():
    surface = models.indentation_block(fine_edge=0.5e-3, fine_radius=3e-3, coarse_edge=8e-3)
    centre = edge_lengths_near(surface, 0.0, 3e-3)
    far = edge_lengths_near(surface, 0.03, 0.06)
    assert 0.4e-3 < np.median(centre) < 0.7e-3       # rings 0.5 mm apart, 0.5 mm along
    assert 5e-3 < np.median(far) < 12e-3             # the coarse grid and its diagonals
    assert surface.triangle_areas.min() > 0.0


def test_the_block_is_deterministic_and_refuses_bad_sizes():
    a, b = models.indentation_block(), models.indentation_block()
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)
    with pytest.raises(MeshError, match="fine_edge"):
        models.indentation_block(fine_edge=-1.0)
    with pytest.raises(MeshError, match="shrink the fine patch"):
        models.indentation_block(fine_radius=0.05)
    with pytest.raises(MeshError, match="growth"):
        models.indentation_block(growth=3.0)
