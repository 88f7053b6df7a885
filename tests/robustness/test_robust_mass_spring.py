"""Issue items on the mass-spring baseline: unbounded substeps, and a surface left inside out after release."""

import numpy as np
import pytest

from tissuesim import HybridMesh, InversionError, SolverError, make_solver
from tissuesim.mesh import models


@pytest.fixture(scope="module")
def sphere():
    return HybridMesh.build(models.sphere(resolution=400))


@pytest.mark.parametrize("options, dt", [({"youngs_modulus": 1e15}, 0.01), ({}, 10.0)])
def test_a_step_needing_too_many_substeps_is_refused_at_once(sphere, options, dt, monkeypatch):
    solver = make_solver("mass-spring", sphere, **options)
    calls = []
    monkeypatch.setattr("tissuesim.solvers.mass_spring.mass_spring_step", lambda *args: calls.append(args))
    with pytest.raises(SolverError, match=r"substeps at dt = .* with E = .*lower dt or E"):
        solver.step(dt)
    assert calls == []  # refused before any substep, not after hours of them
    # Exact: a refused step writes nothing, so the state is still the rest positions it was assigned.
    np.testing.assert_array_equal(solver.positions, sphere.surface.vertices)
    np.testing.assert_array_equal(solver.velocities, 0.0)


def test_a_load_that_turns_the_surface_inside_out_is_refused_and_reset_recovers(sphere):
    solver = make_solver("mass-spring", sphere)
    top = int(np.argmax(sphere.surface.vertices[:, 2]))
    solver.set_load(top, [0.0, 0.0, -20.0])
    with pytest.raises(InversionError, match="inside out.*lower the force"):
        for _ in range(300):
            solver.step()
    solver.reset()
    for _ in range(5):
        solver.step()
    np.testing.assert_allclose(solver.positions, sphere.surface.vertices, atol=1e-12)


def test_a_moderate_load_comes_back_to_rest_after_release(sphere):
    solver = make_solver("mass-spring", sphere)
    top = int(np.argmax(sphere.surface.vertices[:, 2]))
    solver.set_load(top, [0.0, 0.0, -1.0])
    for _ in range(100):
        solver.step()
    assert np.abs(solver.positions - sphere.surface.vertices).max() > 1e-4
    solver.clear_load()
    for _ in range(1500):
        solver.step()
    assert np.abs(solver.positions - sphere.surface.vertices).max() < 1e-4
