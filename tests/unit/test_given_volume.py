"""HybridMesh.from_volume: M_V from a mesher of the user's choice (no TetGen), checked against M_S."""

import numpy as np
import pytest

import tissuesim
from tissuesim.errors import MeshError
from tissuesim.mesh import models
from tissuesim.mesh.tetmesh import TetMesh


@pytest.fixture(scope="module")
def built():
    return tissuesim.HybridMesh.build(models.cube(400), fine_volume=False)


def test_the_volume_tetgen_made_gives_the_same_hybrid_mesh(built):
    given = tissuesim.HybridMesh.from_volume(built.surface, built.volume)
    assert np.array_equal(given.control, built.control)
    assert np.array_equal(given.control_volume, built.control_volume)
    assert np.array_equal(given.coarse_surface.vertices, built.coarse_surface.vertices)
    # the same coarse triangles, each as a set of control nodes (their order within M'_S may differ)
    same = {tuple(sorted(t)) for t in given.coarse_surface.triangles.tolist()}
    assert same == {tuple(sorted(t)) for t in built.coarse_surface.triangles.tolist()}
    assert np.array_equal(given.embedding_tet, built.embedding_tet)
    assert np.allclose(given.embedding_barycentric, built.embedding_barycentric, atol=1e-12, rtol=0)
    assert given.info["coarse_volume"] == "given" and given.fine_volume is None


def test_a_solver_on_it_answers_as_on_the_built_one(built, tmp_path):
    given = tissuesim.HybridMesh.load(tissuesim.HybridMesh.from_volume(built.surface, built.volume)
                                      .save(tmp_path / "given.npz"))
    top = int(np.argmax(built.surface.vertices[:, 2]))
    answers = [tissuesim.make_solver("hybrid", mesh).solve_static(top, [0.0, 0.0, -0.2], radius=0.008)
               for mesh in (built, given)]
    assert np.allclose(answers[0], answers[1], atol=1e-12, rtol=0)


def test_a_steiner_point_on_the_boundary_is_refused(built):
    volume = built.volume
    # split one boundary face's tet at the face's centroid: a boundary node that is no vertex of M_S
    face = volume.boundary_triangles[0]
    tet = int(np.flatnonzero(np.isin(volume.tets, face).sum(axis=1) == 3)[0])
    a, b, c = face
    d = int(np.setdiff1d(volume.tets[tet], face)[0])
    centre = len(volume.points)
    points = np.vstack([volume.points, volume.points[face].mean(axis=0)])
    split = [[a, b, centre, d], [b, c, centre, d], [c, a, centre, d]]
    tets = np.vstack([np.delete(volume.tets, tet, axis=0), split])
    signed = np.einsum("ij,ij->i", np.cross(points[tets[:, 1]] - points[tets[:, 0]],
                                            points[tets[:, 2]] - points[tets[:, 0]]),
                       points[tets[:, 3]] - points[tets[:, 0]])
    tets[signed < 0] = tets[signed < 0][:, [1, 0, 2, 3]]
    with pytest.raises(MeshError, match=f"1 of the volume's .* boundary nodes are no vertex of M_S \\(first nodes: "
                                        f"{centre}"):
        tissuesim.HybridMesh.from_volume(built.surface, TetMesh(points, tets))


def test_what_is_no_volume_is_refused(built):
    with pytest.raises(MeshError, match="must be a TetMesh"):
        tissuesim.HybridMesh.from_volume(built.surface, (built.volume.points, built.volume.tets))
    with pytest.raises(MeshError, match="SurfaceMesh"):
        tissuesim.HybridMesh.from_volume("cube", built.volume)
