"""HybridMesh (§5): invariants on the built-in models and the clean shared livers, maps, bundle round trip."""

import json
import zipfile

import numpy as np
import pytest

from tissuesim.errors import BundleError, MeshError
from tissuesim.io import read_surface
from tissuesim.mesh import models
from tissuesim.mesh.bundle import BUNDLE_VERSION
from tissuesim.mesh.hybrid import HybridMesh
from tissuesim.mesh.table1 import ascii_size, table1_markdown, table1_row
from tissuesim.mesh.surface import SurfaceMesh
from tissuesim.mesh.validate import validate_surface

SHARED_LIVERS = {"sofa/liver2": "sofa/liver2.obj", "softbodyliver/liver": "softbodyliver/liver.obj"}


@pytest.fixture(scope="session")
def hybrids(meshes_dir):
    """The four built-in models at their default (Table 1) size and the two clean shared livers (cm -> m)."""
    built = {name: HybridMesh.build(models.model(name), fine_volume=False) for name in sorted(models.MODELS)}
    for name, path in SHARED_LIVERS.items():
        built[name] = HybridMesh.build(read_surface(meshes_dir / path, scale=0.01), fine_volume=name == "sofa/liver2")
    return built


@pytest.fixture(scope="session")
def small_with_fine():
    return HybridMesh.build(models.steak(400), fine_volume=True)


def test_control_nodes_are_surface_vertices_and_the_volume_boundary(hybrids):
    for name, h in hybrids.items():
        n = h.surface.vertex_count
        assert np.all(np.diff(h.control) > 0) and 0 <= h.control[0] and h.control[-1] < n, name
        assert np.array_equal(h.coarse_surface.vertices, h.surface.vertices[h.control]), name  # exact: copied rows
        # M_V boundary node set == control set, coordinates bit-identical.
        assert np.array_equal(np.sort(h.control_volume), h.volume.boundary_nodes), name
        # exact: TetGen Y keeps them
        assert np.array_equal(h.volume.points[h.control_volume], h.surface.vertices[h.control]), name
        assert np.all(h.volume.volumes > 0), name
        validate_surface(h.coarse_surface)
        # Coarse/fine node ratio near Table 1's 0.34-0.42.
        assert 0.3 < h.volume.node_count / n < 0.5, name


def test_coarse_map_is_the_closest_point_on_the_coarse_surface(hybrids):
    for name, h in hybrids.items():
        w = h.coarse_barycentric
        assert np.all(w >= 0) and np.allclose(w.sum(axis=1), 1.0), name
        corners = h.coarse_surface.triangles[h.coarse_triangle]
        # Control nodes map onto themselves with weight 1.
        own = corners[h.control, np.argmax(w[h.control], axis=1)]
        assert np.array_equal(own, np.arange(len(h.control))), name
        # The closest-point search computes the weights: a corner's is 1 up to round-off.
        np.testing.assert_allclose(w[h.control].max(axis=1), 1.0, rtol=0, atol=1e-12, err_msg=name)
        # Against brute force on a sample of vertices: no triangle is closer.
        q = np.einsum("ij,ijk->ik", w, h.coarse_surface.vertices[corners])
        dist = np.linalg.norm(q - h.surface.vertices, axis=1)
        sample = np.arange(0, h.surface.vertex_count, 97)
        brute = _distance_to_triangles(h.surface.vertices[sample], h.coarse_surface)
        assert np.allclose(dist[sample], brute, rtol=1e-9, atol=1e-12), name


def test_embedding_reproduces_every_vertex(hybrids):
    for name, h in hybrids.items():
        w = h.embedding_barycentric
        assert np.allclose(w.sum(axis=1), 1.0), name
        x = np.einsum("ij,ijk->ik", w, h.volume.points[h.volume.tets[h.embedding_tet]])
        assert np.abs(x - h.surface.vertices).max() < 1e-12, name
        assert w.min() > -1.0, name       # outside vertices extrapolate only a little


def test_fine_volume_surface_nodes_are_the_surface_vertices(hybrids, small_with_fine):
    for h in (hybrids["sofa/liver2"], small_with_fine):
        nodes = h.fine_surface_nodes
        assert np.array_equal(h.fine_volume.points[nodes], h.surface.vertices)  # exact: TetGen Y keeps them
        assert np.array_equal(np.sort(nodes), h.fine_volume.boundary_nodes)
        assert np.all(h.fine_volume.volumes > 0)
        assert h.fine_volume.node_count > h.surface.vertex_count        # interior nodes from the quality switch


def test_build_refuses_an_invalid_surface():
    cube = models.cube(100)
    with pytest.raises(MeshError, match="inward"):
        HybridMesh.build(SurfaceMesh(cube.vertices, cube.triangles[:, ::-1]))


def test_bundle_round_trip_is_bit_exact(small_with_fine, tmp_path):
    # Exact throughout: a bundle stores the arrays themselves, so loading must give them back to the bit.
    h = small_with_fine
    path = h.save(tmp_path / "sub" / "steak.npz")
    assert [p.name for p in path.parent.iterdir()] == ["steak.npz"]        # no temporary file left
    g = HybridMesh.load(path)
    for field in ("control", "control_volume", "coarse_triangle", "coarse_barycentric", "embedding_tet",
                  "embedding_barycentric", "fine_surface_nodes"):
        a, b = getattr(h, field), getattr(g, field)
        assert a.dtype == b.dtype and np.array_equal(a, b), field
    for mesh in ("surface", "coarse_surface"):
        assert np.array_equal(getattr(h, mesh).vertices, getattr(g, mesh).vertices)
        assert np.array_equal(getattr(h, mesh).triangles, getattr(g, mesh).triangles)
    for mesh in ("volume", "fine_volume"):
        assert np.array_equal(getattr(h, mesh).points, getattr(g, mesh).points)
        assert np.array_equal(getattr(h, mesh).tets, getattr(g, mesh).tets)
    assert g.info["simplify"] == h.info["simplify"]


def test_bundle_without_fine_volume(hybrids, tmp_path):
    g = HybridMesh.load(hybrids["cube"].save(tmp_path / "cube.npz"))
    assert g.fine_volume is None and g.fine_surface_nodes is None


def test_bundle_of_another_format_version_is_refused(small_with_fine, tmp_path):
    path = small_with_fine.save(tmp_path / "h.npz")
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(arrays["header"].tobytes())
    header["format_version"] = BUNDLE_VERSION + 1
    arrays["header"] = np.frombuffer(json.dumps(header).encode(), dtype=np.uint8)
    np.savez(tmp_path / "future.npz", **arrays)
    with pytest.raises(BundleError, match="format version"):
        HybridMesh.load(tmp_path / "future.npz")


def test_corrupt_or_foreign_bundles_are_refused(small_with_fine, tmp_path):
    path = small_with_fine.save(tmp_path / "h.npz")
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(BundleError):
        HybridMesh.load(truncated)
    (tmp_path / "text.npz").write_text("not a bundle")
    with pytest.raises(BundleError, match="not a readable"):
        HybridMesh.load(tmp_path / "text.npz")
    np.savez(tmp_path / "foreign.npz", x=np.zeros(3))
    with pytest.raises(BundleError, match="no bundle header"):
        HybridMesh.load(tmp_path / "foreign.npz")
    with zipfile.ZipFile(path) as source, zipfile.ZipFile(tmp_path / "partial.npz", "w") as target:
        for item in source.namelist():
            if item != "embedding_tet.npy":
                target.writestr(item, source.read(item))
    with pytest.raises(BundleError, match="embedding_tet"):
        HybridMesh.load(tmp_path / "partial.npz")
    with pytest.raises(FileNotFoundError):
        HybridMesh.load(tmp_path / "missing.npz")


def test_table1_row(small_with_fine, hybrids):
    row = table1_row(small_with_fine)
    assert row["M_S"]["nodes"] == small_with_fine.surface.vertex_count
    assert row["M_V"]["elements"] == small_with_fine.volume.element_count
    assert row["fine"]["nodes"] == small_with_fine.fine_volume.node_count
    assert row["M_S"]["size_kb"] == ascii_size(small_with_fine.surface) / 1000
    assert table1_row(hybrids["cube"])["fine"] is None
    text = table1_markdown({"steak": row, "cube": table1_row(hybrids["cube"])})
    lines = text.splitlines()
    assert len(lines) == 4 and lines[2].startswith("| steak | 400 |") and lines[3].endswith("| - | - | - |")


def test_ascii_size_counts_the_bytes_of_the_files():
    tri = SurfaceMesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    assert ascii_size(tri) == len("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")


def _distance_to_triangles(points, surface):
    """Brute-force point-to-triangle distance by dense sampling plus vertices/edges (for a test, tolerance-free
    via the exact projection formula on every triangle)."""
    p = surface.vertices[surface.triangles]                      # (m, 3, 3)
    out = np.empty(len(points))
    for k, x in enumerate(points):
        out[k] = np.min(_point_triangle_distances(x, p))
    return out


def _point_triangle_distances(x, p):
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    d_plane = np.einsum("ij,ij->i", x - a, n)
    proj = x - d_plane[:, None] * n
    inside = np.ones(len(p), bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, proj - u), n) >= 0
    best = np.where(inside, np.abs(d_plane), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        e = v - u
        t = np.clip(np.einsum("ij,ij->i", x - u, e) / np.einsum("ij,ij->i", e, e), 0, 1)
        best = np.minimum(best, np.linalg.norm(x - (u + t[:, None] * e), axis=1))
    return best
