"""The solver API refuses time steps below MIN_DT (with a message that says so, not "diverged") and other absurd
arguments, every method and integrator, and a refusal leaves the state as it was."""

import numpy as np
import pytest

from tissuesim import PinHead, make_solver
from tissuesim.errors import SolverError
from tissuesim.solvers.checks import MIN_DT

#: (method, options): every method, and both time integrators of the surface-layer methods and the paper's form.
VARIANTS = [
    ("hybrid", {}), ("hybrid", {"integrator": "xpbd"}), ("hybrid", {"form": "pbd"}),
    ("pbd", {}), ("pbd", {"integrator": "xpbd"}), ("pbd", {"form": "pbd"}),
    ("mass-spring", {}), ("embedded", {}), ("fem", {}),
]
IDS = [f"{m}-{'-'.join(o.values()) or 'default'}" for m, o in VARIANTS]


@pytest.fixture(params=VARIANTS, ids=IDS)
def loaded(request, small_cube, small_cube_top):
    """A solver under 1 N on the top node, a few steps away from rest."""
    method, options = request.param
    solver = make_solver(method, small_cube, **options)
    solver.set_load(small_cube_top, [0.0, 0.0, 1.0])
    for _ in range(3):
        solver.step()
    return solver


@pytest.mark.parametrize("dt", [1e-300, 5e-324, 1e-160, 0.5 * MIN_DT])
def test_a_time_step_below_the_floor_is_refused_with_a_true_message(loaded, dt):
    positions, velocities = loaded.positions.copy(), loaded.velocities.copy()
    with pytest.raises(SolverError) as error:
        loaded.step(dt)
    message = str(error.value)
    assert f"dt must lie in [{MIN_DT:g}, ∞) s" in message and f"got {dt!r} s" in message
    assert "round-off" in message and "diverged" not in message and "lower dt" not in message
    # exact: a refused step writes nothing
    assert np.array_equal(loaded.positions, positions) and np.array_equal(loaded.velocities, velocities)


def test_a_step_at_the_floor_stays_finite(loaded):
    loaded.step(MIN_DT)
    assert np.all(np.isfinite(loaded.positions)) and np.all(np.isfinite(loaded.velocities))


@pytest.mark.parametrize("method, options", [v for v in VARIANTS if v[1].get("form") != "pbd"],
                         ids=[i for i, v in zip(IDS, VARIANTS) if v[1].get("form") != "pbd"])
def test_the_default_step_after_one_at_the_floor_is_undisturbed(small_cube, small_cube_top, method, options):
    """Round-off over dt is the only velocity a step at the floor adds. Without damping (it removes a fraction of
    the velocity per step, however short); the paper's pbd form is left out: its projection moves a node by an
    amount that does not shrink with dt, so any change of dt jolts it."""
    solvers = [make_solver(method, small_cube, damping=0.0, **options) for _ in range(2)]
    for solver in solvers:
        solver.set_load(small_cube_top, [0.0, 0.0, 1.0])
        for _ in range(3):
            solver.step()
    solvers[0].step(MIN_DT)
    for solver in solvers:
        solver.step()
    moved = np.abs(solvers[1].displacements).max()
    # 1e-5 of the motion. Measured at the floor: 0 (embedded, fem) to 1e-6 (the XPBD projection, whose trajectory
    # any extra step shifts by 2e-7 to 1e-6, not growing as dt shrinks to 1e-11 s). Round-off over dt grows as 1/dt
    # and reaches 1e-5 near dt = 1e-13 s (pbd 2.4e-5, pbd's xpbd integrator 1.8e-5), 1e-4 to 2e-3 at 1e-15 s.
    assert np.abs(solvers[0].positions - solvers[1].positions).max() <= 1e-5 * moved


@pytest.mark.parametrize("dt", [1e-300, 0.0, -0.01, float("nan"), float("inf"), True, "fast"])
def test_every_way_in_for_dt_refuses_it(small_cube, small_cube_top, dt):
    with pytest.raises(SolverError, match="dt"):
        make_solver("embedded", small_cube, dt=dt)
    solver = make_solver("hybrid", small_cube)
    with pytest.raises(SolverError, match="dt"):
        solver.dt = dt                    # the viewer sets it live
    assert solver.dt == 0.01              # exact: the default, as assigned
    solver.set_load(small_cube_top, [0.0, 0.0, 1.0])
    solver.step()
    positions = solver.positions.copy()
    with pytest.raises(SolverError, match="dt"):
        solver.solve_static(small_cube_top, [0.0, 0.0, 1.0], dt=dt)
    assert np.array_equal(solver.positions, positions)       # exact: refused before the reset


@pytest.mark.parametrize("force", [[1e200, 1e200, 0.0], [np.inf, 0.0, 0.0], [0.0, np.nan, 0.0]])
def test_a_force_whose_magnitude_float64_cannot_hold_is_refused(small_cube, small_cube_top, force):
    solver = make_solver("embedded", small_cube)
    with pytest.raises(SolverError, match="force must be 3 finite numbers"):
        solver.set_load(small_cube_top, force)
    assert solver.load is None and not solver.forces.any()


def test_bools_are_not_numbers(small_cube, small_cube_top):
    solver = make_solver("hybrid", small_cube)
    with pytest.raises(SolverError, match="contact radius"):
        solver.set_load(small_cube_top, [0.0, 0.0, 1.0], radius=True)       # would be a 1 m tip
    with pytest.raises(SolverError, match="stiffness"):
        PinHead(solver, stiffness=True)
    with pytest.raises(SolverError, match="damping"):
        make_solver("pbd", small_cube, damping=False)
    with pytest.raises(SolverError, match="density"):
        make_solver("pbd", small_cube, density=True)


@pytest.mark.parametrize("name", [["hybrid"], None, 3])
def test_a_solver_name_that_is_no_string_is_refused(small_cube, name):
    with pytest.raises(SolverError, match="solver name"):
        make_solver(name, small_cube)


@pytest.mark.parametrize("rtol", [1.0, 1e300])
def test_an_rtol_that_accepts_any_state_is_refused(small_cube, small_cube_top, rtol):
    solver = make_solver("mass-spring", small_cube)
    with pytest.raises(SolverError, match=r"rtol .* must lie in \(0, 1\)"):
        solver.solve_static(small_cube_top, [0.0, 0.0, 1.0], rtol=rtol)
    assert solver.last_solve is None and solver.load is None


def test_a_linear_answer_out_of_range_blames_the_load_not_dt(small_cube, small_cube_top):
    solver = make_solver("embedded", small_cube, youngs_modulus=1e-200)
    with pytest.raises(SolverError, match="lower the load") as error:
        solver.solve_static(small_cube_top, [0.0, 0.0, 1e150])
    assert "dt" not in str(error.value)
