"""Simplification M_S -> M'_S (§5, eq 13-14): invariants, determinism and the local safety predicates."""

import numpy as np
import pytest

from tissuesim.errors import MeshError
from tissuesim.mesh import models
from tissuesim.mesh.collapse import _triangles_intersect
from tissuesim.mesh.simplify import default_target, simplify
from tissuesim.mesh.validate import validate_surface


@pytest.fixture(scope="module")
def simplified_models():
    return {name: (models.model(name, 500), simplify(models.model(name, 500))) for name in sorted(models.MODELS)}


def test_result_is_a_valid_closed_surface_of_original_vertices(simplified_models):
    for name, (fine, result) in simplified_models.items():
        coarse = result.surface
        validate_surface(coarse)            # closed, manifold, outward, no degenerate or intersecting triangles
        assert np.all(np.diff(result.kept) > 0), name
        # Every kept vertex is an M_S vertex at its original position, bit for bit.
        assert np.array_equal(coarse.vertices, fine.vertices[result.kept]), name  # exact: kept rows are copied
        assert coarse.signed_volume > 0.9 * fine.signed_volume, name


def test_reaches_the_default_target_with_the_counts_reported(simplified_models):
    for name, (fine, result) in simplified_models.items():
        report = result.report
        assert result.surface.vertex_count == default_target(fine.vertex_count) == report.vertices, name
        assert report.reached and report.rounds >= 3, name      # one cover round alone removes at most ~1/3
        assert report.collapses == fine.vertex_count - report.vertices, name
        assert set(report.rejected) == {"link", "degree", "degenerate", "normal", "fold", "intersection"}


def test_deterministic():
    surface = models.liver(400)
    a, b = simplify(surface), simplify(surface)
    assert np.array_equal(a.kept, b.kept)
    assert np.array_equal(a.surface.triangles, b.surface.triangles)


def test_cube_keeps_its_corners_and_flat_faces():
    fine = models.cube(600)
    coarse = simplify(fine, target_vertices=150).surface
    lo, hi = fine.bounds
    corners = np.all((np.isclose(coarse.vertices, lo) | np.isclose(coarse.vertices, hi)), axis=1)
    assert corners.sum() == 8            # a corner collapse would turn normals by 90°, above the limit
    assert coarse.signed_volume == pytest.approx(fine.signed_volume, rel=1e-9)


def test_explicit_target_and_strict_limits_are_honoured():
    fine = models.sphere(400)
    result = simplify(fine, target_vertices=200)
    assert result.surface.vertex_count == 200
    # A tiny normal-change limit forbids almost everything: the target is not reached, and it says why.
    strict = simplify(fine, target_vertices=50, max_normal_change=0.5)
    assert not strict.report.reached
    assert strict.report.rejected["normal"] > 0
    validate_surface(strict.surface)


def test_bad_options_raise():
    surface = models.cube(100)
    with pytest.raises(MeshError, match="at least"):
        simplify(surface, target_vertices=3)
    with pytest.raises(MeshError, match="min_quality"):
        simplify(surface, min_quality=1.5)


def test_triangle_intersection_predicate():
    P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0],           # 0-2: triangle in z = 0
                  [0.2, 0.2, -1], [0.2, 0.2, 1], [2, 2, 0.5],  # 3-5: pierces it
                  [0.2, 0.2, 0.5], [0.3, 0.2, 1], [2, 2, 1],  # 6-8: floats above it
                  [0.3, 0.3, -1], [0.3, 0.3, 1]], dtype=float)
    t = (0, 1, 2)
    assert _triangles_intersect(P, t, (3, 4, 5))
    assert not _triangles_intersect(P, t, (6, 7, 8))
    # Sharing vertex 0, the far edge of the second triangle crosses the first.
    assert _triangles_intersect(P, t, (0, 9, 10))
    # Sharing vertex 0 and leaning away: no intersection.
    assert not _triangles_intersect(P, t, (0, 6, 7))
    # An edge neighbour is never an intersection (the fold test handles it); a duplicate always is.
    assert not _triangles_intersect(P, t, (1, 0, 6))
    assert _triangles_intersect(P, t, (2, 1, 0))


def test_aggressive_simplification_of_a_thin_slab_stays_valid():
    # A 2.5 mm thick slab with ~6 mm edges, simplified tenfold with loose limits: top and bottom must not cross.
    fine = models.steak(600)
    thin = fine.with_vertices(fine.vertices * [1.0, 1.0, 0.1])
    result = simplify(thin, target_vertices=60, max_normal_change=89.0, max_fold=179.0, min_quality=0.01)
    assert result.surface.vertex_count == 60
    validate_surface(result.surface)
