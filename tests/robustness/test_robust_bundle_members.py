"""A bundle is read member by member, only the members a hybrid mesh has, each checked by its declared shape and
dtype (the .npy header inside the zip, read without inflating the data) before its data is read: an extra member,
however large it inflates, is never read, and a member whose header or zip entry declares more than the bundle's
counts allow is refused with a BundleError naming it, before anything large is allocated."""

import io
import tracemalloc
import zipfile

import numpy as np
import pytest

from tissuesim import BundleError, HybridMesh
from tissuesim.mesh.bundle import MAX_INFLATION

#: Bytes of zeros in the compressible extra member: 64 MiB, deflated to about 64 KiB.
EXTRA_BYTES = 64 * 2 ** 20


@pytest.fixture(scope="module")
def saved(small_cube, tmp_path_factory):
    return small_cube.save(tmp_path_factory.mktemp("bundle") / "cube.npz")


def _npy(array: np.ndarray, *, shape=None) -> bytes:
    """``array`` as .npy bytes, its header declaring ``shape`` if given (the data stays ``array``'s)."""
    stream = io.BytesIO()
    header = np.lib.format.header_data_from_array_1_0(array)
    if shape is not None:
        header["shape"] = shape
    np.lib.format.write_array_header_1_0(stream, header)
    stream.write(array.tobytes())
    return stream.getvalue()


def _rewritten(saved, path, *, replace=None, add=None, compress=()):
    """A copy of the bundle ``saved`` at ``path``: members ``replace`` (name → .npy bytes) replaced, ``add`` added,
    those named in ``compress`` deflated, the rest stored as HybridMesh.save stores them."""
    replace, add = replace or {}, add or {}
    with zipfile.ZipFile(saved) as source, zipfile.ZipFile(path, "w") as target:
        for info in source.infolist():
            name = info.filename[:-4]
            data = replace.get(name, source.read(info))
            target.writestr(info.filename, data,
                            zipfile.ZIP_DEFLATED if name in compress else zipfile.ZIP_STORED)
        for name, data in add.items():
            target.writestr(f"{name}.npy", data, zipfile.ZIP_DEFLATED if name in compress else zipfile.ZIP_STORED)
    return path


def _same(loaded, original):
    return (np.array_equal(loaded.surface.vertices, original.surface.vertices)
            and np.array_equal(loaded.volume.tets, original.volume.tets)
            and np.array_equal(loaded.embedding_barycentric, original.embedding_barycentric))


def test_an_extra_member_that_inflates_far_is_never_read(saved, small_cube, tmp_path):
    bomb = _rewritten(saved, tmp_path / "bomb.npz", add={"extra": _npy(np.zeros(EXTRA_BYTES, dtype=np.uint8))},
                      compress={"extra"})
    assert bomb.stat().st_size < EXTRA_BYTES / 100
    tracemalloc.start()
    try:
        loaded = HybridMesh.load(bomb)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert _same(loaded, small_cube)
    assert peak < EXTRA_BYTES / 8, f"loading allocated {peak / 2 ** 20:.1f} MiB at its peak"


def test_an_extra_member_declaring_a_huge_shape_is_never_read(saved, small_cube, tmp_path):
    """Its header declares 3.2 GB of float64 that its entry does not hold: reading it would allocate them."""
    forged = _rewritten(saved, tmp_path / "forged.npz", add={"extra": _npy(np.zeros(4), shape=(400_000_000,))})
    assert _same(HybridMesh.load(forged), small_cube)


def test_a_member_declaring_a_huge_shape_is_refused_by_name_before_it_is_read(saved, small_cube, tmp_path):
    vertices = np.asarray(small_cube.surface.vertices)
    forged = _rewritten(saved, tmp_path / "forged.npz", replace={"surface_vertices": _npy(vertices,
                                                                                         shape=(10 ** 9, 3))})
    tracemalloc.start()
    try:
        with pytest.raises(BundleError, match=r"array surface_vertices declares shape \(1000000000, 3\) of float64 "
                                              r"\(24000000000 bytes\) but its entry holds \d+ bytes.*rebuild it"):
            HybridMesh.load(forged)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 * 2 ** 20


def test_a_member_whose_rows_disagree_with_the_counts_is_refused_before_it_is_read(saved, small_cube, tmp_path):
    """8 MiB of embedding tets, stored as a bundle stores them: the header's row count is refused against the
    surface's before the data is read."""
    rows = 2 ** 20
    forged = _rewritten(saved, tmp_path / "rows.npz", replace={"embedding_tet": _npy(np.zeros(rows, np.int64))})
    tracemalloc.start()
    try:
        with pytest.raises(BundleError, match=rf"array embedding_tet has {rows} rows, expected "
                                              rf"{small_cube.surface.vertex_count}"):
            HybridMesh.load(forged)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2 * 2 ** 20


def test_a_member_that_inflates_beyond_what_a_mesh_compresses_to_is_refused(saved, tmp_path):
    """A surface of 2.8 million zero vertices (64 MiB) deflates about a thousandfold; a mesh's arrays compress
    below tenfold."""
    zeros = np.zeros((EXTRA_BYTES // 24, 3))
    forged = _rewritten(saved, tmp_path / "zeros.npz", replace={"surface_vertices": _npy(zeros)},
                        compress={"surface_vertices"})
    with pytest.raises(BundleError, match=rf"member surface_vertices inflates .* more than {MAX_INFLATION}"):
        HybridMesh.load(forged)


def test_a_member_of_python_objects_is_refused_before_it_is_read(saved, tmp_path):
    stream = io.BytesIO()
    np.lib.format.write_array_header_1_0(stream, {"descr": "|O", "fortran_order": False, "shape": (3,)})
    forged = _rewritten(saved, tmp_path / "objects.npz", replace={"control": stream.getvalue() + b"\x00" * 24})
    with pytest.raises(BundleError, match="control.*Python objects"):
        HybridMesh.load(forged)


def test_a_deflated_bundle_of_a_real_mesh_still_loads(saved, small_cube, tmp_path):
    with zipfile.ZipFile(saved) as source:
        names = {info.filename[:-4] for info in source.infolist()}
    compressed = _rewritten(saved, tmp_path / "deflated.npz", compress=names)
    assert _same(HybridMesh.load(compressed), small_cube)
