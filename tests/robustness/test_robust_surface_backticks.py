"""A surface reader's message never quotes the file: meshio quotes a PLY header line in backticks ("got
`element vertex ...`"), which passed the filter of quoted words."""

import pytest

from tissuesim import MeshError, read_surface


def test_a_malformed_ply_header_is_not_quoted(tmp_path):
    path = tmp_path / "header.ply"
    path.write_text("ply\nformat ascii 1.0\nelement vertex qzxsecret\nproperty float x\nend_header\n")
    with pytest.raises(MeshError, match=r"cannot read .*header.ply as PLY") as refused:
        read_surface(path)
    assert "qzx" not in str(refused.value)
