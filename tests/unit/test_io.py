"""Reading and writing surfaces: formats, seam merging, polygons, units, and the errors for bad files."""

import logging

import meshio
import numpy as np
import pytest

from tissuesim.errors import MeshError
from tissuesim.io import read_surface, surface_from_polygons, write_surface
from tissuesim.mesh import models

OBJ_WITH_SEAMS = """# a tetrahedron whose vertex 0 is duplicated along a UV seam (vertex 5), with an unused vertex 6
mtllib tet.mtl
o tet
v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
v 0.0 0.0 0.0
v 9 9 9
vt 0 0
vt 1 0
vt 0 1
vn 0 0 -1
usemtl skin
s off
f 1/1/1 3/2/1 2/3/1
f 5/1/1 2/2/1 4/3/1
f 1//1 4//1 3//1
f -5 -4 -3
"""


def test_obj_merges_seams_drops_unused_and_scales(tmp_path):
    path = tmp_path / "tet.obj"
    path.write_text(OBJ_WITH_SEAMS)
    surface = read_surface(path, scale=0.01)
    assert surface.vertex_count == 4 and surface.triangle_count == 4
    # exact: 1 × 0.01
    np.testing.assert_array_equal(surface.vertices, [[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]])
    assert surface.triangles[1].tolist() == [0, 1, 3]  # the seam copy 5 became vertex 0
    assert surface.signed_volume == pytest.approx(1e-6 / 6)


def test_merge_is_exact_and_keeps_file_order():
    # -0.0 equals 0.0; a vertex 1e-15 away stays separate.
    v = np.array([[1.0, 0, 0], [0.0, 0, 0], [-0.0, 0, 0], [0, 1e-15, 0], [0, 0, 1]])
    s = surface_from_polygons(v, [np.array([[0, 1, 4], [2, 3, 4]])])
    assert s.vertex_count == 4
    np.testing.assert_array_equal(s.triangles, [[0, 1, 3], [1, 2, 3]])


def test_quads_split_along_the_shorter_diagonal_and_polygons_fan():
    v = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1.5, 0], [-1, 0.5, 0]], dtype=float)
    quad = surface_from_polygons(v, [np.array([[0, 1, 2, 3]])])
    assert quad.triangles.tolist() == [[0, 1, 2], [0, 2, 3]]  # |02|² = 5 < |13|² = 6.25
    pentagon = surface_from_polygons(v, [np.array([[0, 1, 2, 3, 4]])])
    assert pentagon.triangles.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]]


@pytest.mark.parametrize("ext", [".obj", ".stl", ".ply", ".off", ".vtk", ".vtu"])
def test_round_trip_every_format(tmp_path, ext):
    sphere = models.sphere(200)
    path = tmp_path / f"sphere{ext}"
    write_surface(path, sphere)
    back = read_surface(path)
    assert back.vertex_count == sphere.vertex_count and back.triangle_count == sphere.triangle_count
    # STL stores float32 and has no shared vertices: the merge must restore the connectivity exactly.
    tol = 1e-7 if ext == ".stl" else 1e-12
    np.testing.assert_allclose(back.vertices[back.triangles], sphere.vertices[sphere.triangles], atol=tol)


def test_quad_cube_from_meshio_is_triangulated(tmp_path):
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    path = tmp_path / "cube.ply"
    meshio.write(path, meshio.Mesh(v, [("quad", quads)]))
    cube = read_surface(path, scale=0.1)
    assert cube.triangle_count == 12 and cube.signed_volume == pytest.approx(1e-3)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="surface file not found: .*nope.obj"):
        read_surface(tmp_path / "nope.obj")


@pytest.mark.parametrize(
    "name, text, message",
    [
        ("mesh.xyz", "1 2 3", r"unknown extension '.xyz'; use one of .obj, .stl"),
        ("points.obj", "v 0 0 0\nv 1 0 0\n", "no triangle or polygon faces"),
        ("bad.obj", "v 0 0 0\nv 1 zero 0\n", r"bad.obj:2: malformed vertex line"),
        ("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "refers to vertex 7 but the file has only 3"),
        ("bad.obj", "v 0 0 0\nf 1 2\n", "at least 3 corners"),
        ("bad.obj", "v 0 0 0\nf 0 1 1\n", "face index 0 is invalid"),
        ("garbage.stl", "this is not an stl file", "cannot read .*garbage.stl as STL"),
        ("empty.off", "", "cannot read .*empty.off as OFF"),
    ],
)
def test_bad_files_get_one_line_errors(tmp_path, name, text, message):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(MeshError, match=message) as info:
        read_surface(path)
    assert "\n" not in str(info.value)


def test_volume_mesh_is_refused(tmp_path):
    path = tmp_path / "tet.vtu"
    meshio.write(path, meshio.Mesh(np.eye(4, 3), [("tetra", np.array([[0, 1, 2, 3]]))]))
    with pytest.raises(MeshError, match=r"no triangle or polygon faces \(found 1 tetra cells: a volume mesh\)"):
        read_surface(path)


@pytest.mark.parametrize("scale", [0.0, -1.0, float("nan"), "0.01"])
def test_bad_scale(tmp_path, scale):
    with pytest.raises(MeshError, match="scale must be a positive finite number"):
        read_surface(tmp_path / "x.obj", scale=scale)


def test_bad_mesh_is_refused_unchanged_or_repaired_with_a_log(tmp_path, caplog):
    cube = models.cube(100)
    inward = cube.with_vertices(cube.vertices)
    path = tmp_path / "inward.obj"
    write_surface(path, type(cube)(inward.vertices, inward.triangles[:, ::-1]))
    with pytest.raises(MeshError, match="faces point inward"):
        read_surface(path)
    with caplog.at_level(logging.WARNING, logger="tissuesim.repair"):
        fixed = read_surface(path, repair=True)
    np.testing.assert_array_equal(fixed.triangles, cube.triangles)
    assert any("reversed all" in r.getMessage() and "inward.obj" in r.getMessage() for r in caplog.records)


def test_write_unknown_extension(tmp_path):
    with pytest.raises(MeshError, match="cannot write x.dae: unknown extension"):
        write_surface(tmp_path / "x.dae", models.cube(50))
