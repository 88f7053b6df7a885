"""The long part of the sweep: random pin-head drags on every method (slow; ``pytest -m slow``).

Each run grabs, drags and releases at random for 2000 steps, sometimes grabbing with a live row of the solver's
positions (as a viewer might). A method may refuse a drag with a SolverError naming a divergence; it must never
hold a non-finite position silently, and the force stays eq 24's k (x − x0) with x0 the grab point.
"""

import numpy as np
import pytest

from tissuesim import PinHead, SolverError, make_solver

STEPS = 2000


@pytest.mark.slow
@pytest.mark.parametrize("method", ["hybrid", "pbd", "mass-spring", "embedded", "fem"])
def test_random_drags_never_leave_a_silent_nan(small_cube, method):
    rng = np.random.default_rng(11)
    solver = make_solver(method, small_cube)
    pin = PinHead(solver, stiffness=20.0)
    top = np.flatnonzero(small_cube.surface.vertices[:, 2] > small_cube.surface.vertices[:, 2].max() - 1e-9)
    cursor = None
    divergences = 0
    for step in range(STEPS):
        if not pin.grabbed and rng.random() < 0.05:
            node = int(rng.choice(top))
            cursor = solver.positions[node].copy()
            grab_point = cursor.copy()
            pin.grab(solver.positions[node] if rng.random() < 0.5 else cursor)
        elif pin.grabbed and rng.random() < 0.01:
            pin.release()
        if pin.grabbed:
            cursor += rng.normal(scale=0.002, size=3)       # the caller's cursor array, moved in place
            assert np.allclose(pin.drag(cursor), 20.0 * (cursor - grab_point)), f"eq 24 broken at step {step}"
        try:
            solver.step()
        except SolverError as error:
            assert "diverged" in str(error)
            divergences += 1
            pin.release()
            solver.reset()
        assert np.all(np.isfinite(solver.positions)), f"non-finite positions at step {step}"
    assert divergences <= STEPS // 100
