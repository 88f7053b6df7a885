import numpy as np
import pytest

from tissuesim.errors import MeshError
from tissuesim.mesh.surface import SurfaceMesh
from tissuesim.mesh.tetmesh import TetMesh

UNIT_TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)


def test_tetmesh_volume_and_outward_boundary():
    mesh = TetMesh(UNIT_TET, [[0, 1, 2, 3]])
    assert mesh.volumes[0] == pytest.approx(1 / 6)
    boundary = SurfaceMesh(mesh.points, mesh.boundary_triangles)
    assert boundary.signed_volume == pytest.approx(1 / 6)
    assert mesh.boundary_nodes.tolist() == [0, 1, 2, 3]


def test_inverted_tet_is_named():
    with pytest.raises(MeshError, match=r"1 inverted tets .*first: 1\)"):
        TetMesh(UNIT_TET, [[0, 1, 2, 3], [0, 2, 1, 3]])


def test_degenerate_tet_is_named():
    flat = np.vstack([UNIT_TET, [[1, 1, 0]]])
    with pytest.raises(MeshError, match="degenerate .*first: 1"):
        TetMesh(flat, [[0, 1, 2, 3], [0, 1, 4, 2]])


@pytest.mark.parametrize(
    "points, tets, message",
    [
        (UNIT_TET[:, :2], [[0, 1, 2, 3]], "shape"),
        (UNIT_TET, [[0, 1, 2, 4]], "outside 0..3"),
        (np.where(np.eye(4, 3, dtype=bool), np.nan, UNIT_TET), [[0, 1, 2, 3]], "non-finite"),
    ],
)
def test_tetmesh_bad_arrays(points, tets, message):
    with pytest.raises(MeshError, match=message):
        TetMesh(points, tets)


def test_surface_rejects_bad_indices_and_is_read_only():
    with pytest.raises(MeshError, match="outside 0..2"):
        SurfaceMesh(UNIT_TET[:3], [[0, 1, 3]])
    surface = SurfaceMesh(UNIT_TET, [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    assert surface.signed_volume == pytest.approx(1 / 6)
    assert len(surface.edges) == 6
    with pytest.raises(ValueError):
        surface.vertices[0, 0] = 1.0
