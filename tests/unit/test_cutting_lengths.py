"""Eq 19–23: new rest lengths from the original ones equal the distances between the new rest positions."""

import numpy as np
import pytest

from tissuesim.cutting.lengths import barycentric_distance, edge_point_length, facet_point_length

RNG = np.random.default_rng(7)
TRIANGLES = RNG.normal(size=(20, 3, 3))


def _sides(p):
    return np.linalg.norm(p[:, 0] - p[:, 1], axis=1), np.linalg.norm(p[:, 1] - p[:, 2], axis=1), \
        np.linalg.norm(p[:, 0] - p[:, 2], axis=1)


def test_eq19_edge_point():
    l_ab, _, _ = _sides(TRIANGLES)
    lam1 = RNG.uniform(0.05, 0.95, 20)
    point = lam1[:, None] * TRIANGLES[:, 0] + (1 - lam1)[:, None] * TRIANGLES[:, 1]
    expected = np.linalg.norm(point - TRIANGLES[:, 0], axis=1)
    assert edge_point_length(l_ab, lam1, 1 - lam1) == pytest.approx(expected, rel=1e-12)


def test_eq20_to_23_facet_point():
    l_ab, l_bc, l_ac = _sides(TRIANGLES)
    lam = RNG.dirichlet([2, 2, 2], size=20)
    point = np.einsum("ij,ijk->ik", lam, TRIANGLES)
    expected = np.linalg.norm(point - TRIANGLES[:, 0], axis=1)
    assert facet_point_length(l_ab, l_bc, l_ac, lam) == pytest.approx(expected, rel=1e-10)


def test_general_form_between_any_two_points_of_a_triangle():
    l_ab, l_bc, l_ac = _sides(TRIANGLES)
    first, second = RNG.dirichlet([1, 1, 1], size=20), RNG.dirichlet([1, 1, 1], size=20)
    expected = np.linalg.norm(np.einsum("ij,ijk->ik", first - second, TRIANGLES), axis=1)
    lengths = np.stack([l_ab, l_bc, l_ac], axis=1)
    assert barycentric_distance(lengths, first, second) == pytest.approx(expected, rel=1e-10)
    corner = np.tile([1.0, 0.0, 0.0], (20, 1))
    assert barycentric_distance(lengths, corner, first) == pytest.approx(
        facet_point_length(l_ab, l_bc, l_ac, first), rel=1e-10)
