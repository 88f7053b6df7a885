"""A bundle that is no readable archive of plain arrays is refused with a BundleError that says what kind of damage
it has, never the reader's own text, which quotes the file's bytes (a .npy magic string, a header's keys): a study or
a service may load a bundle written by someone else. A damaged deflate stream is refused too, not a zlib traceback."""

import io
import zipfile

import numpy as np
import pytest

from tissuesim import BundleError, HybridMesh

SECRET = "qzx:secret:7731"


@pytest.fixture(scope="module")
def saved(small_cube, tmp_path_factory):
    return small_cube.save(tmp_path_factory.mktemp("unreadable") / "cube.npz")


def _copy(saved, path, *, replace=None, compress=False):
    """The bundle ``saved`` at ``path``, members ``replace`` (name → bytes) replaced, every member deflated if
    ``compress``."""
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with zipfile.ZipFile(saved) as source, zipfile.ZipFile(path, "w", method) as target:
        for info in source.infolist():
            target.writestr(info.filename, (replace or {}).get(info.filename[:-4], source.read(info)))
    return path


def _npy_with_header_keys(keys: str) -> bytes:
    stream = io.BytesIO()
    np.lib.format.write_array(stream, np.zeros(3, dtype=np.uint8))
    return stream.getvalue().replace(b"'descr'", keys.encode())


@pytest.mark.parametrize("member, data", [
    ("header", (SECRET + "\n").encode() * 4),                     # not a .npy at all: numpy quotes its first bytes
    ("header", _npy_with_header_keys(f"'{SECRET}'")),             # a .npy header with other keys: numpy lists them
    ("surface_vertices", (SECRET + "\n").encode() * 4),
], ids=["header-text", "header-keys", "array-text"])
def test_a_member_that_is_no_npy_array_is_refused_without_quoting_it(saved, tmp_path, member, data):
    path = _copy(saved, tmp_path / "forged.npz", replace={member: data})
    with pytest.raises(BundleError, match="not a readable hybrid-mesh bundle") as refused:
        HybridMesh.load(path)
    assert SECRET[:4] not in str(refused.value)      # numpy quotes the first 6 bytes


def test_a_header_that_is_no_utf8_text_is_refused_without_quoting_it(saved, tmp_path):
    stream = io.BytesIO()
    np.lib.format.write_array(stream, np.frombuffer(b"\xff" + SECRET.encode(), dtype=np.uint8))
    path = _copy(saved, tmp_path / "header.npz", replace={"header": stream.getvalue()})
    with pytest.raises(BundleError, match="corrupt bundle header") as refused:
        HybridMesh.load(path)
    assert "0xff" not in str(refused.value)


def test_a_damaged_deflate_stream_is_refused(saved, tmp_path):
    path = _copy(saved, tmp_path / "deflated.npz", compress=True)
    assert HybridMesh.load(path).surface.vertex_count > 0        # deflated members are read
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as archive:
        info = archive.getinfo("surface_vertices.npy")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra) + 40
    data[start:start + 160] = bytes(byte ^ 0x55 for byte in data[start:start + 160])
    path.write_bytes(bytes(data))
    with pytest.raises(BundleError, match="not a readable hybrid-mesh bundle.*damaged"):
        HybridMesh.load(path)
