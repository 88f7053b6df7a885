"""Fixed regions: each selector takes exactly the nodes its geometry names, the spec entry point agrees with the
selectors, files are read as written, and bad input is refused naming the fix."""

import numpy as np
import pytest

from tissuesim.commands.fixing import DEFAULT_FIX, check_fix, parse_fix
from tissuesim.errors import BoundaryConditionError
from tissuesim.mesh.models import CUBE_EDGE, cube
from tissuesim.mesh.regions import bottom_nodes, fixed_region, nodes_behind_plane, nodes_in_box

POINTS = cube(300).vertices     # an 8 cm cube on z = 0, centred on the z axis


def test_a_plane_holds_the_nodes_on_and_behind_it_whatever_the_normals_length():
    height = 0.3 * CUBE_EDGE
    expected = np.flatnonzero(POINTS[:, 2] <= height + 1e-12)
    for length in (1.0, 1e-3, 7.0):
        selected = nodes_behind_plane(POINTS, [0.0, 0.0, height], [0.0, 0.0, length])
        np.testing.assert_array_equal(selected, expected)
        assert selected.dtype == np.int32


def test_a_plane_through_a_face_takes_the_whole_face():
    face = np.flatnonzero(np.abs(POINTS[:, 0] - 0.5 * CUBE_EDGE) < 1e-12)
    selected = nodes_behind_plane(POINTS, [0.5 * CUBE_EDGE, 0.0, 0.0], [-1.0, 0.0, 0.0])
    np.testing.assert_array_equal(selected, face)


def test_an_oblique_plane_takes_the_half_space_it_bounds():
    normal = np.array([1.0, 1.0, 1.0]) / np.sqrt(3.0)
    point = np.array([0.0, 0.0, 0.5 * CUBE_EDGE])
    expected = np.flatnonzero((POINTS - point) @ normal <= 1e-12)
    assert 0 < expected.size < len(POINTS)
    np.testing.assert_array_equal(nodes_behind_plane(POINTS, point, 2.0 * normal), expected)


@pytest.mark.parametrize("spec, expected", [
    ({"bottom": 0.25}, lambda: bottom_nodes(POINTS, fraction=0.25)),
    ({"box": {"lower": [-1, -1, 0.0], "upper": [0.0, 1, 0.02]}},
     lambda: nodes_in_box(POINTS, [-1, -1, 0], [0, 1, 0.02])),
    ({"plane": {"point": [0, 0, 0.01], "normal": [0, 0, 1]}}, lambda: np.flatnonzero(POINTS[:, 2] <= 0.01)),
    ({"indices": [7, 3, 3, 11]}, lambda: np.array([3, 7, 11])),
])
def test_the_spec_selects_what_its_selector_does(spec, expected):
    selected = fixed_region(spec, POINTS)
    assert selected.dtype == np.int32 and selected.ndim == 1
    np.testing.assert_array_equal(selected, expected())


def test_a_mask_file_in_text_or_npy_and_an_index_file_select_their_vertices(tmp_path):
    held = np.zeros(len(POINTS), dtype=np.int8)
    held[[2, 5, 40]] = 1
    np.save(tmp_path / "held.npy", held)
    np.savetxt(tmp_path / "held.txt", held, fmt="%d", header="one 0/1 per vertex")
    (tmp_path / "ids.txt").write_text("40\n2, 5  # three vertices\n")
    for spec in ({"mask": "held.npy"}, {"mask": "held.txt"}, {"indices_file": "ids.txt"}):
        np.testing.assert_array_equal(fixed_region(spec, POINTS, folder=tmp_path), [2, 5, 40])
    np.testing.assert_array_equal(fixed_region({"mask": str(tmp_path / "held.npy")}, POINTS), [2, 5, 40])


@pytest.mark.parametrize("spec, words", [
    ({"plane": {"point": [0, 0, -0.01], "normal": [0, 0, 1]}}, ["no node", "flip the normal"]),
    ({"plane": {"point": [0, 0, 0], "normal": [0, 0, 0]}}, ["zero vector", "0,0,1"]),
    ({"plane": {"point": [0, 0], "normal": [0, 0, 1]}}, ["three finite numbers"]),
    ({"box": {"lower": [1, 1, 1], "upper": [2, 2, 2]}}, ["no node lies in the box"]),
    ({"box": {"lower": [0, 0, 0]}}, ["exactly the keys lower and upper"]),
    ({"bottom": 1.5}, ["(0, 1)"]),
    ({"bottom": "low"}, ["fraction"]),
    ({"indices": []}, ["non-empty"]),
    ({"indices": [0, 10_000]}, ["outside 0..295"]),
    ({"hold": 1}, ["unknown fixed region 'hold'", "bottom, box, plane"]),
    ({"bottom": 0.1, "indices": [1]}, ["exactly one"]),
    ([0.1], ["exactly one"]),
])
def test_a_bad_spec_is_refused_naming_the_defect(spec, words):
    with pytest.raises(BoundaryConditionError) as error:
        fixed_region(spec, POINTS)
    assert all(word in str(error.value) for word in words), str(error.value)


def test_a_mask_of_another_length_or_with_other_values_or_none_held_is_refused(tmp_path):
    np.save(tmp_path / "short.npy", np.ones(len(POINTS) - 1, dtype=np.int8))
    (tmp_path / "two.txt").write_text("\n".join(["2"] + ["0"] * (len(POINTS) - 1)))
    np.save(tmp_path / "none.npy", np.zeros(len(POINTS)))
    (tmp_path / "words.txt").write_text("yes no")
    cases = {"short.npy": f"{len(POINTS) - 1} entries but the model has {len(POINTS)} surface vertices",
             "two.txt": "neither 0 nor 1 (first at vertices 0", "none.npy": "selects no vertex",
             "words.txt": "cannot read the mask file", "absent.npy": "does not exist"}
    for name, words in cases.items():
        with pytest.raises(BoundaryConditionError) as error:
            fixed_region({"mask": name}, POINTS, folder=tmp_path)
        assert words in str(error.value), str(error.value)


@pytest.mark.parametrize("text, spec", [
    (DEFAULT_FIX, {"bottom": 0.1}),
    ("box:-0.04,-0.04,0:0.04,0.04,0.01", {"box": {"lower": [-0.04, -0.04, 0.0], "upper": [0.04, 0.04, 0.01]}}),
    ("plane:0,0,0.01:0,0,1", {"plane": {"point": [0.0, 0.0, 0.01], "normal": [0.0, 0.0, 1.0]}}),
    ("mask:held.npy", {"mask": "held.npy"}),
    ("indices:C:/data/ids.txt", {"indices_file": "C:/data/ids.txt"}),
])
def test_fix_text_becomes_the_spec(text, spec):
    assert parse_fix(text) == spec


@pytest.mark.parametrize("text, words", [
    ("top:0.1", "is not a region"), ("box:0,0,0", "is not a region"), ("plane:0,0:0,0,1", "'0,0' must be 3 numbers"),
    ("bottom:x", "'x' must be a number"), ("mask:", "is not a region"), ("bottom:inf", "must be a number"),
])
def test_bad_fix_text_is_refused_in_one_line(text, words):
    with pytest.raises(BoundaryConditionError) as error:
        parse_fix(text)
    assert words in str(error.value) and "\n" not in str(error.value)


def test_a_missing_fix_file_is_refused_before_any_work(tmp_path):
    with pytest.raises(BoundaryConditionError, match="does not exist"):
        check_fix(f"mask:{tmp_path / 'absent.npy'}")
