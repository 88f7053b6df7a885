"""The contact protocol's finite-strain reference: its small-load limit is the linear reference on the same levels,
a load with no stable equilibrium is marked and refused, and it is cached whole; at its shipped level it is the
scikit-fem reference computed independently."""

import numpy as np
import pytest

from tissuesim.errors import SolverError
from tissuesim.experiments import finite_contact, protocol, reference
from tissuesim.mesh import models

LEVEL_ZERO = reference.RefinementSettings(max_levels=0)
RADIUS = 0.008


@pytest.fixture(scope="module")
def cube():
    surface = models.model("cube", 400)
    return surface, protocol.load_node(surface.vertices, surface.triangles)


def _relative(a, b) -> float:
    return float(np.sqrt(np.sum((a - b) ** 2) / np.sum(b ** 2)))


def test_at_a_small_load_it_is_the_linear_reference_of_the_same_level(cube):
    surface, node = cube
    linear = reference.contact_reference(surface, node, RADIUS, settings=LEVEL_ZERO)
    small = (0.0, 0.0, 1e-3)
    finite = finite_contact.finite_contact_reference(surface, node, RADIUS, [small], settings=LEVEL_ZERO)
    # first order in the load: at 1 mN the finite answer is the linear one to well under 1 %
    assert _relative(finite.displacements(small)[linear.samples], linear.displacements(small)[linear.samples]) < 1e-2
    pull = (0.0, 0.0, 2.0)
    large = finite_contact.finite_contact_reference(surface, node, RADIUS, [pull], settings=LEVEL_ZERO)
    # and at 2 N it is not (the shape changes: the question the reference exists to answer)
    assert _relative(large.displacements(pull)[linear.samples], linear.displacements(pull)[linear.samples]) > 0.05


def test_loads_of_one_direction_are_reached_in_turn_and_looked_up_by_force(cube):
    surface, node = cube
    loads = [(0.0, 0.0, 1.0), (0.0, 0.0, 0.5)]
    both = finite_contact.finite_contact_reference(surface, node, RADIUS, loads, settings=LEVEL_ZERO)
    alone = finite_contact.finite_contact_reference(surface, node, RADIUS, loads[1:], settings=LEVEL_ZERO)
    # the same equilibrium whether reached from rest or from the smaller load's answer (Newton's tolerance 1e-9)
    np.testing.assert_allclose(both.displacements(loads[1]), alone.displacements(loads[1]), atol=1e-9)
    assert np.linalg.norm(both.displacements(loads[0])[node]) > np.linalg.norm(both.displacements(loads[1])[node])
    with pytest.raises(SolverError, match="has no load"):
        both.displacements((0.0, 0.0, 2.0))


def test_a_load_with_no_stable_equilibrium_is_marked_and_refused_and_so_are_larger_ones(cube, monkeypatch):
    from tissuesim.fem.nonlinear import UnstableLoadError
    from tissuesim.fem.nonlinear_quadratic import QuadraticNonlinearFEM

    surface, node = cube
    solve = QuadraticNonlinearFEM.solve

    def unstable_above_a_newton(self, forces, **options):    # Newton's own detection is tested with the FEM
        if forces.sum(axis=0)[2] < -1.0 + 1e-9:
            raise UnstableLoadError("no stable equilibrium", reached=0.5)
        return solve(self, forces, **options)

    monkeypatch.setattr(QuadraticNonlinearFEM, "solve", unstable_above_a_newton)
    loads = [(0.0, 0.0, -3.0), (0.0, 0.0, -0.1), (0.0, 0.0, -2.0), (0.0, 0.0, 0.5)]
    result = finite_contact.finite_contact_reference(surface, node, RADIUS, loads, settings=LEVEL_ZERO)
    assert result.unstable.tolist() == [True, False, True, False]
    assert np.isnan(result.fields[[0, 2]]).all() and np.isfinite(result.fields[[1, 3]]).all()
    with pytest.raises(SolverError, match="no stable equilibrium"):
        result.displacements(loads[0])


def test_it_is_cached_whole_and_keyed_by_the_material(cube, tmp_path, monkeypatch):
    surface, node = cube
    loads = [(0.0, 0.0, 0.5)]
    first = finite_contact.finite_contact_reference(surface, node, RADIUS, loads, settings=LEVEL_ZERO,
                                                    cache_dir=tmp_path)

    def never(*args, **kwargs):
        raise AssertionError("recomputed a cached reference")

    monkeypatch.setattr(finite_contact, "_compute", never)
    again = finite_contact.finite_contact_reference(surface, node, RADIUS, loads, settings=LEVEL_ZERO,
                                                    cache_dir=tmp_path)
    np.testing.assert_array_equal(again.fields, first.fields)
    assert again.levels == first.levels and again.material == "neo-hookean"
    with pytest.raises(AssertionError, match="recomputed"):
        finite_contact.finite_contact_reference(surface, node, RADIUS, loads, material="corotated",
                                                settings=LEVEL_ZERO, cache_dir=tmp_path)
    for entry in tmp_path.glob("*.npz"):    # a damaged entry is recomputed, never trusted
        entry.write_bytes(b"not a zip")
    with pytest.raises(AssertionError, match="recomputed"):
        finite_contact.finite_contact_reference(surface, node, RADIUS, loads, settings=LEVEL_ZERO,
                                                cache_dir=tmp_path)


@pytest.mark.parametrize("material, loads, message", [
    ("linear", [(0, 0, 1.0)], "needs a finite-strain material"),
    ("neo-hookean", [(0, 0, 0.0)], "nonzero finite loads"),
    ("neo-hookean", [(0, 0, np.nan)], "nonzero finite loads"),
])
def test_bad_material_and_loads_are_refused(cube, material, loads, message):
    surface, node = cube
    with pytest.raises(SolverError, match=message):
        finite_contact.finite_contact_reference(surface, node, RADIUS, loads, material=material,
                                                settings=LEVEL_ZERO)


@pytest.mark.slow
def test_at_the_shipped_level_it_is_the_scikit_fem_reference():
    """The shipped reference was computed by scikit-fem's P2 Newton on the same levels (about 4 minutes here;
    measured: 1e-12 apart)."""
    from tissuesim.experiments.finite_reference import load_finite_reference

    shipped = load_finite_reference()
    surface = models.model(shipped.model)
    loads = [(0.0, 0.0, f) for f in shipped.forces]
    ours = finite_contact.finite_contact_reference(
        surface, shipped.load_node, 1e-3 * shipped.radius_mm, loads,
        settings=reference.RefinementSettings(max_levels=len(shipped.levels) - 1, min_levels=len(shipped.levels)))
    for load, force in zip(loads, shipped.forces):
        # both Newton solves stop at a residual of 1e-9 of the load; the quadrature is the same degree-2 rule
        assert _relative(ours.displacements(load)[shipped.samples], shipped.displacements[force]) < 1e-5
