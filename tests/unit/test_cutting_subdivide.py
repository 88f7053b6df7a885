"""The Fig 7 cases, each on one flat triangle: pieces tile the parent, keep its orientation, make no sliver, and
contain the cut segment as an edge."""

import numpy as np
import pytest

from tissuesim.cutting.subdivide import (split_full_cut, split_interior_cut, split_partial_cut, split_uncut,
                                         triangle_quality)
from tissuesim.errors import MeshError

A, B, C = np.array([0.0, 0.0]), np.array([1.0, 0.0]), np.array([0.3, 0.9])
AREA = 0.5 * 0.9


def _areas(points, triangles):
    p = points[triangles]
    return 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                  - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))


def _edges(triangles):
    return {tuple(sorted((int(t[i]), int(t[(i + 1) % 3])))) for t in triangles for i in range(3)}


def _check_tiling(points, triangles):
    areas = _areas(points, triangles)
    assert np.all(areas > 1e-3 * AREA), "a piece is a sliver or turned over"
    assert areas.sum() == pytest.approx(AREA, rel=1e-12)


def test_uncut_with_one_edge_point_gives_two_triangles():             # Fig 7(a)
    polygon = np.array([A, (A + B) / 2, B, C])
    pieces = split_uncut(polygon)
    assert len(pieces) == 2
    _check_tiling(polygon, pieces)


def test_uncut_with_points_on_every_side_never_uses_three_collinear_points():
    polygon = np.array([A, 0.5 * (A + B), B, 0.5 * (B + C), C, 0.5 * (C + A)])
    pieces = split_uncut(polygon)
    assert len(pieces) == 4
    _check_tiling(polygon, pieces)


def test_full_cut_between_two_edge_points_makes_the_chord_an_edge():    # Fig 7(c)
    polygon = np.array([A, 0.4 * A + 0.6 * B, B, 0.5 * (B + C), C])
    pieces = split_full_cut(polygon, 1, 3)
    assert len(pieces) == 3
    _check_tiling(polygon, pieces)
    assert (1, 3) in _edges(pieces)


def test_full_cut_from_a_corner_to_the_opposite_side():
    polygon = np.array([A, B, 0.5 * (B + C), C])
    pieces = split_full_cut(polygon, 0, 2)
    assert len(pieces) == 2
    assert (0, 2) in _edges(pieces)
    _check_tiling(polygon, pieces)


def test_partial_cut_fans_from_the_facet_point():                       # Fig 7(b)
    polygon = np.array([A, 0.5 * (A + B), B, C])
    facet = (A + B + C) / 3
    pieces = split_partial_cut(polygon, facet)
    points = np.concatenate([polygon, facet[None]])
    assert len(pieces) == 4
    _check_tiling(points, pieces)
    assert (1, 4) in _edges(pieces)


def test_partial_cut_refuses_a_facet_point_on_the_boundary():
    with pytest.raises(MeshError, match="strictly inside"):
        split_partial_cut(np.array([A, B, C]), (A + B) / 2)


@pytest.mark.parametrize("second", [(0.45, 0.35), (0.5, 0.2), (0.31, 0.45)])
def test_interior_cut_joins_both_facet_points(second):
    polygon = np.array([A, B, C])
    first, second = np.array([0.4, 0.3]), np.array(second)
    pieces = split_interior_cut(polygon, first, second, snap=0.25)
    points = np.concatenate([polygon, first[None], second[None]])
    _check_tiling(points, pieces)
    assert (3, 4) in _edges(pieces)


def test_quality_is_one_for_equilateral_and_zero_when_flat():
    assert triangle_quality(A, B, np.array([0.5, np.sqrt(3) / 2])) == pytest.approx(1.0)
    assert triangle_quality(A, B, np.array([2.0, 0.0])) == 0.0  # exact: collinear small integers, area 0 to the bit
