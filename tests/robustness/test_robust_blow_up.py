"""Sweep item 2: a blow-up (non-finite or runaway state) is detected at once, named, and reset() recovers."""

import numpy as np
import pytest

from tissuesim import PinHead, SolverError, make_solver


def test_a_stiff_pin_head_blow_up_raises_and_reset_recovers(small_cube, small_cube_top):
    solver = make_solver("hybrid", small_cube)
    pin = PinHead(solver, stiffness=1e12)
    rest = small_cube.surface.vertices
    pin.grab(rest[small_cube_top].copy())
    with pytest.raises(SolverError, match=r"diverged.*ran .* from rest.*lower dt, the load or the pin-head stiffness"):
        for _ in range(300):
            pin.drag(rest[small_cube_top] + [0.0, 0.0, 0.01])
            solver.step()
    pin.release()
    solver.reset()
    fresh = make_solver("hybrid", small_cube).solve_static(small_cube_top, [0.0, 0.0, 1.0])
    assert np.array_equal(solver.solve_static(small_cube_top, [0.0, 0.0, 1.0]), fresh)


def test_a_non_finite_state_is_caught_on_the_next_step(small_cube, small_cube_top):
    solver = make_solver("pbd", small_cube)
    solver.set_load(small_cube_top, [0.0, 0.0, 1.0])
    solver.state.positions[7, 1] = np.nan           # what a kernel that blew up leaves behind
    with pytest.raises(SolverError, match="diverged.*has a non-finite position"):
        solver.step()


def test_a_runaway_dynamic_solver_is_stopped_at_the_first_step_beyond_the_bound(small_cube, small_cube_top,
                                                                                small_cube_size):
    solver = make_solver("pbd", small_cube)
    solver.set_load(small_cube_top, [0.0, 0.0, 1e6])
    rest = small_cube.surface.vertices
    with pytest.raises(SolverError, match="more than 100 times the model's size"):
        for _ in range(200):
            before = np.linalg.norm(solver.positions - rest, axis=1).max()
            solver.step()
    assert before <= 100 * small_cube_size      # the step that crossed the bound raised, not a later one


@pytest.mark.parametrize("method", ["hybrid", "fem"])
def test_solve_static_calls_a_divergence_a_divergence(small_cube, method):
    solver = make_solver(method, small_cube)
    # The paper's largest load on a corner moves the cube ~15 sizes: large, but no blow-up.
    corner = int(np.argmax(small_cube.surface.vertices.sum(axis=1)))
    assert np.all(np.isfinite(solver.solve_static(corner, [0.0, 0.0, 20.0], max_steps=2000)))
    with pytest.raises(SolverError) as caught:
        solver.solve_static(corner, [0.0, 0.0, 1e6])
    assert "diverged" in str(caught.value)
    assert "max_steps" not in str(caught.value)
