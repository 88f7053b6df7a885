"""Random pin-head drags on every method: 2000 steps from each of several seeds in the slow run
(``--run-slow``), 200 steps from one seed per method by default.

Each run grabs, drags and releases at random, sometimes grabbing with a live row of the solver's positions (as a
viewer might). A method may refuse a drag with a SolverError naming a divergence; it must never hold a non-finite
position silently, and the force stays eq 24's k (x − x0) with x0 the grab point. Every message names the seed and
the step, so a failure replays with that seed alone.
"""

import numpy as np
import pytest

from tissuesim import PinHead, SolverError, make_solver
from tissuesim.solvers import available_solvers

METHODS = available_solvers()


@pytest.mark.slow
@pytest.mark.parametrize("seed", [11, 12, 13, 14])
@pytest.mark.parametrize("method", METHODS)
def test_random_drags_never_leave_a_silent_nan(small_cube, method, seed):
    random_drags(small_cube, method, seed=seed, steps=2000)


@pytest.mark.parametrize("method", METHODS)
def test_random_drags_never_leave_a_silent_nan_quick(small_cube, method):
    random_drags(small_cube, method, seed=METHODS.index(method) + 21, steps=200)


def random_drags(small_cube, method, *, seed, steps):
    """``steps`` steps of random grabs, drags and releases drawn from ``seed``; asserts as in the module docstring."""
    rng = np.random.default_rng(seed)
    solver = make_solver(method, small_cube)
    pin = PinHead(solver, stiffness=20.0)
    top = np.flatnonzero(small_cube.surface.vertices[:, 2] > small_cube.surface.vertices[:, 2].max() - 1e-9)
    cursor = None
    divergences = 0
    for step in range(steps):
        if not pin.grabbed and rng.random() < 0.05:
            node = int(rng.choice(top))
            cursor = solver.positions[node].copy()
            grab_point = cursor.copy()
            pin.grab(solver.positions[node] if rng.random() < 0.5 else cursor)
        elif pin.grabbed and rng.random() < 0.01:
            pin.release()
        if pin.grabbed:
            cursor += rng.normal(scale=0.002, size=3)       # the caller's cursor array, moved in place
            force = pin.drag(cursor)
            # rtol 1e-9: one subtraction and one product in float64, far below any wrong grab point or stiffness
            assert np.allclose(force, 20.0 * (cursor - grab_point), rtol=1e-9, atol=0.0), \
                f"eq 24 broken at step {step} (seed {seed})"
        try:
            solver.step()
        except SolverError as error:
            assert "diverged" in str(error), f"seed {seed}, step {step}: {error}"
            divergences += 1
            pin.release()
            solver.reset()
        assert np.all(np.isfinite(solver.positions)), f"non-finite positions at step {step} (seed {seed})"
    assert divergences <= steps // 100, f"{divergences} divergences in {steps} steps (seed {seed})"
