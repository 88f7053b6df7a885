"""Contact loads (tissuesim.loads and Solver.set_load(radius=...)): the patch, its shares, the same nodal forces for
every method, and refusals."""

import numpy as np
import pytest

from tissuesim import HybridMesh, SolverError, make_solver
from tissuesim.loads import contact_patch, lumped_areas
from tissuesim.mesh import models
from tissuesim.solvers import available_solvers


@pytest.fixture(scope="module")
def sphere():
    return HybridMesh.build(models.sphere(resolution=400))


def test_lumped_areas_sum_to_the_surface_area(sphere):
    s = sphere.surface
    np.testing.assert_allclose(lumped_areas(s.vertices, s.triangles).sum(), s.triangle_areas.sum(), rtol=1e-12)


def test_patch_holds_the_nodes_within_the_radius_with_area_weighted_shares(sphere):
    s = sphere.surface
    top = int(np.argmax(s.vertices[:, 2]))
    nodes, shares = contact_patch(s.vertices, s.triangles, top, 0.012)
    distance = np.linalg.norm(s.vertices - s.vertices[top], axis=1)
    assert nodes[0] == top
    assert set(nodes) == set(np.flatnonzero(distance <= 0.012))
    areas = lumped_areas(s.vertices, s.triangles)[nodes]
    np.testing.assert_allclose(shares, areas / areas.sum())


def test_no_radius_is_the_single_node_load(sphere):
    nodes, shares = contact_patch(sphere.surface.vertices, sphere.surface.triangles, 7, None)
    assert nodes.tolist() == [7] and shares.tolist() == [1.0]


@pytest.mark.parametrize("method", available_solvers())
def test_every_method_gets_the_same_nodal_forces(sphere, method):
    top = int(np.argmax(sphere.surface.vertices[:, 2]))
    solver = make_solver(method, sphere)
    solver.set_load(top, [0.0, 0.0, -2.0], radius=0.012)
    reference = make_solver("embedded", sphere)
    reference.set_load(top, [0.0, 0.0, -2.0], radius=0.012)
    # The same patch and shares for every method: equal up to round-off of the area weights.
    np.testing.assert_allclose(solver.forces, reference.forces, rtol=0, atol=1e-15 * 2.0)
    np.testing.assert_allclose(solver.forces.sum(axis=0), [0.0, 0.0, -2.0], atol=1e-14)
    node, total = solver.load
    assert node == top and np.allclose(total, [0.0, 0.0, -2.0])
    solver.clear_load()
    assert not solver.forces.any() and solver.load is None


@pytest.mark.parametrize("radius", [0.0, -0.01, float("nan"), float("inf"), "wide"])
def test_bad_radius_is_refused(sphere, radius):
    with pytest.raises(SolverError, match="contact radius"):
        make_solver("embedded", sphere).set_load(0, [0.0, 0.0, 1.0], radius=radius)


def test_patch_reaching_the_fixed_region_is_refused(sphere):
    top = int(np.argmax(sphere.surface.vertices[:, 2]))
    solver = make_solver("hybrid", sphere)
    with pytest.raises(SolverError, match="reaches the fixed region"):
        solver.solve_static(top, [0.0, 0.0, -1.0], radius=1.0)


def test_a_wider_tip_spreads_the_load_and_lowers_the_peak(sphere):
    top = int(np.argmax(sphere.surface.vertices[:, 2]))
    rest = sphere.surface.vertices
    fem = make_solver("fem", sphere)
    point = fem.solve_static(top, [0.0, 0.0, -1.0])[top] - rest[top]
    spread = fem.solve_static(top, [0.0, 0.0, -1.0], radius=0.015)[top] - rest[top]
    assert 0.0 < -spread[2] < -point[2]
