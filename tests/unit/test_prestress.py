"""The prestressed surface (tissuesim.layer.prestress): the area gradient, the release at a cut's lips, and a wound
that gapes without a load on the surface-layer methods, where stepping comes to rest for every dt and E."""

import numpy as np
import pytest

import tissuesim
from tissuesim.experiments.wound import scripted_incision, unloaded_openings, wound_gap
from tissuesim.errors import SolverError
from tissuesim.mesh import models
from tissuesim.layer.prestress import area_gradient, copy_origin, release_forces
from tissuesim.loads import triangle_areas
from tissuesim.solvers import method_names
from tissuesim.solvers.surface_layer import SurfaceLayerSolver

LAYER = method_names(where=lambda cls: issubclass(cls, SurfaceLayerSolver))     # the surface-layer methods


@pytest.fixture(scope="module")
def cube():
    return tissuesim.HybridMesh.build(models.cube(), fine_volume=False)


def test_area_gradient_matches_finite_differences():
    surface = models.sphere(200)
    x, tri = np.array(surface.vertices), surface.triangles
    gradient = area_gradient(x, tri)
    rng = np.random.default_rng(0)
    for v in rng.choice(len(x), 5, replace=False):
        for k in range(3):
            step = np.zeros_like(x)
            step[v, k] = 1e-7
            numeric = (triangle_areas(x + step, tri).sum() - triangle_areas(x - step, tri).sum()) / 2e-7
            assert gradient[v, k] == pytest.approx(numeric, rel=1e-5, abs=1e-12)
    # a closed surface's area does not change under a translation
    assert np.abs(gradient.sum(axis=0)).max() < 1e-12


def test_release_is_zero_without_copies_and_balanced_at_the_lips(cube):
    surface = cube.surface
    n = surface.vertex_count
    assert not release_forces(surface.vertices, surface.triangles, np.arange(n), 3.0).any()
    solver = tissuesim.make_solver("hybrid", cube, prestrain=0.05)
    scripted_incision(solver)
    origin = copy_origin(solver.rest_positions)
    assert np.array_equal(origin, solver.active_cut_updater.identity)     # the mesh alone tells the copies
    forces = release_forces(solver.rest_positions, solver.hybrid.surface.triangles, origin, 3.0)
    copied = np.bincount(origin)[origin] > 1
    assert not forces[~copied].any()
    assert np.abs(forces[copied]).max() > 0.0
    group_sum = np.zeros((len(origin), 3))
    np.add.at(group_sum, origin, forces)
    assert np.abs(group_sum).max() < 1e-12 * np.abs(forces).max() * 10


@pytest.mark.parametrize("method", LAYER)
def test_uncut_prestrained_surface_does_not_move(cube, method):
    plain = tissuesim.make_solver(method, cube)
    tense = tissuesim.make_solver(method, cube, prestrain=0.1)
    node = int(np.argmax(cube.surface.vertices[:, 2]))
    expected = plain.solve_static(node, [0.0, 0.0, -0.2], radius=0.006)
    moved = np.abs(expected - cube.surface.vertices).max()
    # Round-off of the same solve (1e-12 of the motion): a tension of even 1e-6 of the prestrain's would show.
    assert np.abs(tense.solve_static(node, [0.0, 0.0, -0.2], radius=0.006) - expected).max() <= 1e-12 * moved
    tense.reset()
    for _ in range(20):
        tense.step()
    size = np.ptp(cube.surface.vertices, axis=0).max()
    assert np.abs(tense.positions - tense.rest_positions).max() <= 1e-12 * size


@pytest.mark.parametrize("method", LAYER)
def test_wound_gapes_without_force_and_stepping_rests_there_for_any_dt_and_e(cube, method):
    """The static gap is linear in ε and free of E by construction (the tension and the layer both scale with E); the
    stepped path, where dt and E also set the dynamics, must come to rest at it. rel 1e-6: 400 implicit steps settle
    far below that (the motion decays geometrically), and the rest is the static solve's to round-off."""
    solver = tissuesim.make_solver(method, cube, prestrain=0.05)
    line = scripted_incision(solver)["line"]
    gap = unloaded_openings(solver, line).max()
    assert gap > 1e-3                       # millimetres, with no force at all
    for dt in (0.005, 0.02):
        solver.reset()
        for _ in range(400):
            solver.step(dt)
        assert wound_gap(solver) == pytest.approx(gap, rel=1e-6)
    stiff = tissuesim.make_solver(method, cube, prestrain=0.05, youngs_modulus=55000.0)
    scripted_incision(stiff)
    stiff.reset()
    for _ in range(400):
        stiff.step()
    assert wound_gap(stiff) == pytest.approx(gap, rel=1e-6)


def test_a_solver_built_on_a_cut_mesh_releases_the_same_tension(cube):
    cutting = tissuesim.make_solver("hybrid", cube, prestrain=0.05)
    line = scripted_incision(cutting)["line"]
    fresh = tissuesim.make_solver("hybrid", cutting.hybrid, prestrain=0.05)    # e.g. the viewer switching method
    np.testing.assert_allclose(unloaded_openings(fresh, line), unloaded_openings(cutting, line), rtol=1e-9)


def test_unprestrained_wound_stays_closed_without_force(cube):
    solver = tissuesim.make_solver("hybrid", cube)
    run = scripted_incision(solver)
    assert not unloaded_openings(solver, run["line"]).any()


@pytest.mark.parametrize("bad", [-0.01, 0.31, float("nan"), float("inf"), "five", "0.05"])
def test_bad_prestrain_is_refused(cube, bad):
    with pytest.raises(SolverError, match="prestrain"):
        tissuesim.make_solver("hybrid", cube, prestrain=bad)


@pytest.mark.parametrize("method,options", [("hybrid", {"form": "pbd"}), ("pbd", {"integrator": "xpbd"}),
                                            ("embedded", {}), ("mass-spring", {})])
def test_methods_without_a_tension_refuse_a_prestrain(cube, method, options):
    with pytest.raises(SolverError, match="prestrain"):
        tissuesim.make_solver(method, cube, prestrain=0.05, **options)


def test_release_and_load_superpose_after_a_cut(cube):
    """Small strain: the cut, prestrained, loaded wound is the sum of the load's answer and the release's."""
    tense = tissuesim.make_solver("hybrid", cube, prestrain=0.05)
    scripted_incision(tense)
    plain = tissuesim.make_solver("hybrid", tense.hybrid)
    node = int(np.argmax(tense.rest_positions[:, 2]))
    rest = tense.rest_positions
    released = tense.solve_static(node, [0.0, 0.0, 0.0]) - rest
    loaded = plain.solve_static(node, [0.0, 0.1, -0.1]) - rest
    both = tense.solve_static(node, [0.0, 0.1, -0.1]) - rest
    np.testing.assert_allclose(both, released + loaded, atol=1e-12)
    tense.set_load(node, [0.0, 0.0, 0.0])           # the load withdrawn again: the release alone
    for _ in range(300):
        tense.step()
    np.testing.assert_allclose(tense.positions - rest, released, atol=1e-9)
