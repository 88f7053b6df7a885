"""TetGen tetrahedralization with the boundary preserved (§5 step 3)."""

import numpy as np
import pytest

from tissuesim.errors import MeshError
from tissuesim.mesh import models
from tissuesim.mesh.surface import SurfaceMesh
from tissuesim.mesh.tetrahedralize import FINE_SWITCHES, tetrahedralize


@pytest.mark.parametrize("switches", ["pYq1.8/12", FINE_SWITCHES, "pY"])
def test_boundary_is_the_input_surface(switches):
    surface = models.liver(300)
    volume, nodes = tetrahedralize(surface, switches=switches)
    assert np.array_equal(volume.points[nodes], surface.vertices)      # bit for bit
    assert np.array_equal(volume.boundary_nodes, np.sort(nodes))
    assert np.all(volume.volumes > 0)
    assert volume.volumes.sum() == pytest.approx(surface.signed_volume, rel=1e-9)
    faces = {tuple(sorted(f)) for f in nodes[surface.triangles].tolist()}
    assert faces == {tuple(sorted(f)) for f in volume.boundary_triangles.tolist()}


def test_quality_switch_adds_interior_nodes_only():
    surface = models.sphere(300)
    plain, _ = tetrahedralize(surface, switches="pY")
    quality, _ = tetrahedralize(surface, switches="pYq1.2/15")
    assert plain.node_count == surface.vertex_count
    assert quality.node_count > surface.vertex_count
    assert quality.boundary_nodes.size == surface.vertex_count


def test_switches_without_boundary_preservation_are_refused():
    with pytest.raises(MeshError, match="'Y'"):
        tetrahedralize(models.cube(100), switches="pq1.2")


def test_self_intersecting_surface_gives_a_mesh_error():
    a, b = models.cube(100), models.cube(100)
    # Two overlapping cubes in one surface: TetGen refuses self-intersections.
    vertices = np.vstack([a.vertices, b.vertices + [0.02, 0.02, 0.02]])
    triangles = np.vstack([a.triangles, b.triangles + a.vertex_count])
    with pytest.raises(MeshError, match="TetGen"):
        tetrahedralize(SurfaceMesh(vertices, triangles))
