"""Sweep item 7: a valid ASCII STL that meshio's reader refuses (trimesh's, blank line before endsolid) is read."""

import numpy as np
import pytest
import trimesh

from tissuesim import MeshError, read_surface
from tissuesim.mesh import models


def test_an_ascii_stl_written_by_trimesh_is_read(tmp_path):
    sphere = models.sphere(resolution=200)
    path = tmp_path / "sphere.stl"
    path.write_text(trimesh.exchange.stl.export_stl_ascii(trimesh.Trimesh(sphere.vertices, sphere.triangles,
                                                                          process=False)))
    assert "\n\nendsolid" in path.read_text()
    surface = read_surface(path)
    assert surface.vertex_count == sphere.vertex_count and surface.triangle_count == sphere.triangle_count
    assert np.allclose(np.sort(surface.vertices, axis=0), np.sort(sphere.vertices, axis=0), atol=1e-12)


def test_a_truncated_stl_names_both_readers(tmp_path):
    path = tmp_path / "broken.stl"
    path.write_text("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0\n")
    with pytest.raises(MeshError, match=r"cannot read .*broken.stl as STL: .*\(meshio\).*\(trimesh\)"):
        read_surface(path)
