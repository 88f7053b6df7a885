"""Each surface check on a small synthetic mesh with exactly one defect, and the triangle-triangle predicates."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from tissuesim.errors import MeshError
from tissuesim.mesh import intersections as X
from tissuesim.mesh import validate as V
from tissuesim.mesh.repair import repair_surface
from tissuesim.mesh.surface import SurfaceMesh

TET_POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
TET_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])  # outward


# A closed tet whose face (0, 1, 3) is split at vertex 4 on edge (0, 1), closed by the flat triangle (0, 1, 4).
CAPPED = np.array([[0, 2, 1], [0, 4, 3], [4, 1, 3], [0, 3, 2], [1, 2, 3], [0, 1, 4]])


def tet(offset=(0.0, 0.0, 0.0)):
    return SurfaceMesh(TET_POINTS + offset, TET_FACES)


def box():
    """A closed, outward unit cube of 12 triangles."""
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    f = [[q[0], q[1], q[2]] for q in quads] + [[q[0], q[2], q[3]] for q in quads]
    return SurfaceMesh(v, f)


def merge(*meshes):
    vertices, faces, offset = [], [], 0
    for m in meshes:
        vertices.append(m.vertices)
        faces.append(m.triangles + offset)
        offset += m.vertex_count
    return SurfaceMesh(np.concatenate(vertices), np.concatenate(faces))


def test_clean_meshes_have_no_defects():
    for mesh in (tet(), box()):
        assert V.surface_defects(mesh) == []
        V.validate_surface(mesh)
    assert box().signed_volume == pytest.approx(1.0)


def test_open_box_reports_its_rim():
    mesh = SurfaceMesh(box().vertices, box().triangles[1:])
    assert len(V.boundary_edges(mesh)) == 3
    with pytest.raises(MeshError, match=r"not closed: 3 boundary edges \(first: \(0, 1\)"):
        V.validate_surface(mesh)


def test_two_cubes_are_two_components():
    mesh = merge(box(), SurfaceMesh(box().vertices + 3.0, box().triangles))
    count, labels = V.component_labels(mesh)
    assert count == 2 and np.bincount(labels).tolist() == [12, 12]
    with pytest.raises(MeshError, match=r"2 connected components \(triangle counts 12, 12; .*: 12\)"):
        V.validate_surface(mesh)


def test_flipped_face_is_inconsistent_and_repaired():
    t = box().triangles.copy()
    t[4] = t[4, ::-1]
    mesh = SurfaceMesh(box().vertices, t)
    assert len(V.inconsistent_edges(mesh)) == 3
    with pytest.raises(MeshError, match="inconsistent orientation: 3 edges"):
        V.validate_surface(mesh)
    fixed, changes = repair_surface(mesh)
    assert changes == ["reoriented 1 triangles to make the orientation consistent"]
    np.testing.assert_array_equal(fixed.triangles, box().triangles)


def test_inward_cube_is_refused_then_reversed():
    mesh = SurfaceMesh(box().vertices, box().triangles[:, ::-1])
    assert V.faces_inward(mesh)
    with pytest.raises(MeshError, match=r"faces point inward \(signed volume -1 m³"):
        V.validate_surface(mesh)
    fixed, changes = repair_surface(mesh)
    assert fixed.signed_volume == pytest.approx(1.0) and fixed.vertex_count == 8
    assert "reversed all 12 triangles" in changes[0]


def test_two_tets_sharing_a_vertex_make_a_nonmanifold_vertex():
    second = SurfaceMesh(-TET_POINTS, TET_FACES[:, ::-1])  # point reflection: vertex 0 stays at the origin
    mesh = merge(tet(), second)
    v = np.concatenate([mesh.vertices[:4], mesh.vertices[5:]])
    t = mesh.triangles.copy()
    t[t == 4] = 0
    t[t > 4] -= 1
    mesh = SurfaceMesh(v, t)
    assert V.nonmanifold_vertices(mesh).tolist() == [0]
    assert len(V.boundary_edges(mesh)) == 0 and len(V.nonmanifold_edges(mesh)) == 0
    with pytest.raises(MeshError, match=r"1 non-manifold vertices .*first: 0\)"):
        V.validate_surface(mesh)


def test_three_faces_on_one_edge():
    # A tet plus a flap triangle on edge (0, 1).
    mesh = SurfaceMesh(np.vstack([TET_POINTS, [[0.5, -1.0, -1.0]]]), np.vstack([TET_FACES, [[0, 4, 1]]]))
    assert V.nonmanifold_edges(mesh).tolist() == [[0, 1]]
    with pytest.raises(MeshError, match=r"1 non-manifold edges .*\(0, 1\)"):
        V.validate_surface(mesh)


def test_zero_area_triangle_is_degenerate():
    v = np.vstack([TET_POINTS, [[0.5, 0.0, 0.0]]])  # vertex 4 on edge (0, 1)
    mesh = SurfaceMesh(v, [[0, 4, 1], [0, 2, 1]])
    assert V.degenerate_triangles(mesh).tolist() == [0]
    assert V.degenerate_triangles(SurfaceMesh(v, [[0, 0, 1]])).tolist() == [0]
    # Small but well-shaped is not degenerate.
    assert V.degenerate_triangles(SurfaceMesh(TET_POINTS * 1e-9, TET_FACES)).size == 0
    with pytest.raises(MeshError, match=r"1 degenerate triangles .*first: 5\)"):
        V.validate_surface(SurfaceMesh(v, CAPPED))


def test_duplicated_face_is_removed_only_when_it_keeps_the_surface_closed():
    # A face listed twice plus its mirror: removing the repeated-vertex sliver (0, 0, 1) is safe.
    mesh = SurfaceMesh(TET_POINTS, np.vstack([TET_FACES, [[0, 0, 1]]]))
    fixed, changes = repair_surface(mesh)
    assert fixed.triangle_count == 4 and "removed 1 degenerate triangles" in changes[0]
    V.validate_surface(fixed)
    # A flat triangle with distinct corners cannot go without opening the surface.
    v = np.vstack([TET_POINTS, [[0.5, 0.0, 0.0]]])
    mesh = SurfaceMesh(v, CAPPED)
    assert len(V.boundary_edges(mesh)) == 0
    _, changes = repair_surface(mesh)
    assert changes[0] == "kept 1 degenerate triangles: removing them would open the surface"


def test_crossing_tets_self_intersect():
    mesh = merge(tet(), tet((0.2, 0.2, 0.2)))
    pairs = V.self_intersections(mesh)
    assert len(pairs) > 0 and np.all(pairs[:, 0] < 4) and np.all(pairs[:, 1] >= 4)
    assert V.self_intersections(merge(tet(), tet((2.0, 0.0, 0.0)))).shape == (0, 2)


def test_shared_vertex_and_shared_edge_pairs():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.2, 0.0], [2, 2, 1]], dtype=float)
    # Sharing vertex 0, coplanar, overlapping wedges: intersect beyond the shared vertex.
    assert len(V.self_intersections(SurfaceMesh(v, [[0, 1, 2], [0, 4, 3]]))) == 1
    # Sharing vertex 0, meeting only there.
    assert len(V.self_intersections(SurfaceMesh(v, [[0, 1, 4], [0, 5, 2]]))) == 0
    # Sharing edge (0, 1), coplanar and folded onto each other; then the same edge unfolded.
    assert len(V.self_intersections(SurfaceMesh(v, [[0, 1, 2], [0, 1, 4]]))) == 1
    assert len(V.self_intersections(SurfaceMesh(v, [[0, 1, 2], [1, 0, v.shape[0] - 1]]))) == 0
    v2 = np.vstack([v, [[0.5, -1.0, 0.0]]])
    assert len(V.self_intersections(SurfaceMesh(v2, [[0, 1, 2], [1, 0, 6]]))) == 0
    # A triangle listed twice overlaps itself.
    assert V.self_intersections(SurfaceMesh(v, [[0, 1, 2], [2, 0, 1]])).tolist() == [[0, 1]]


def _reference(a, b):
    """Two non-degenerate triangles meet iff an edge of one meets the other: an independent check."""
    return any(X.segment_intersects_triangle(a[[i, (i + 1) % 3]], b)
               or X.segment_intersects_triangle(b[[i, (i + 1) % 3]], a) for i in range(3))


coords = st.integers(0, 3).map(float)
triangle = st.lists(st.tuples(coords, coords, coords), min_size=3, max_size=3).map(np.array).filter(
    lambda t: np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0])) > 0)


@settings(max_examples=150, deadline=None)
@given(triangle, triangle)
def test_devillers_guigue_matches_edge_tests_on_a_grid(a, b):
    # Small integer coordinates make touching, collinear and coplanar cases common, and exact in float64.
    assert X.triangles_intersect(a, b) == _reference(a, b)
    assert X.triangles_intersect(b, a) == X.triangles_intersect(a, b)


def test_devillers_guigue_matches_edge_tests_at_random():
    rng = np.random.default_rng(7)
    for _ in range(2000):
        a, b = rng.random((3, 3)), rng.random((3, 3))
        assert X.triangles_intersect(a, b) == _reference(a, b)


def test_empty_surface_is_refused():
    with pytest.raises(MeshError, match="no triangles"):
        V.validate_surface(SurfaceMesh(np.zeros((0, 3)), np.zeros((0, 3), int)))
