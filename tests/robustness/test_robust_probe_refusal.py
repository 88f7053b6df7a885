"""N4: a refused press changes nothing. A ``press_static`` that did not converge raised SolverError but left its last
iteration's loads acting (0.7-1.0 N) and the body moved by millimetres, so the next step kept pushing; the probe's
state, loads and the solver's whole state are now as before the call, and the steps that follow equal a twin's that
never tried it."""

import numpy as np
import pytest

from tissuesim import SolverError, make_solver
from tissuesim.tools.probe import Probe
from tissuesim.solvers import available_solvers

#: every method: the probe presses each through its own solve_static
METHODS = available_solvers()
RADIUS = 0.012      # [m] larger than the small cube's triangles
TOP = 0.08          # [m] the small cube's top
#: [m] how far two twins may differ after the same steps: round-off of one solve (both take the very same operations
#: when the refusal put back everything, so they agree far closer)
SAME = 1e-14


def pressed(small_cube, method, **options):
    """A solver under a load beside the top's centre, stepped, and a probe converged 0.3 R into the top."""
    solver = make_solver(method, small_cube, **options)
    corner = int(np.argmax(solver.rest_positions @ [1.0, 1.0, 1.0]))
    solver.add_load(corner, [0.0, 0.0, 0.05])
    solver.step()
    probe = Probe(solver, radius=RADIUS)
    probe.press_static([0.0, 0.0, TOP + RADIUS - 0.3 * RADIUS])
    solver.step()
    return solver, probe


def state(solver, probe) -> dict:
    return {"positions": solver.positions.copy(), "velocities": solver.velocities.copy(),
            "forces": solver.forces.copy(), "loads": [(load.node, load.force.copy()) for load in solver.loads],
            "probe": (probe.center.copy(), probe.scale, probe.iterations, probe.steps, probe.residual),
            "contacts": probe.contacts, "force": probe.force, "largest": solver.largest_displacement}


def assert_same(a: dict, b: dict) -> None:
    for name in ("positions", "velocities", "forces", "contacts", "force"):
        assert np.array_equal(a[name], b[name]), name
    assert len(a["loads"]) == len(b["loads"])
    for (node, force), (other, others) in zip(a["loads"], b["loads"]):
        assert node == other and np.array_equal(force, others)
    (centre, *numbers), (other, *others) = a["probe"], b["probe"]
    assert np.array_equal(centre, other) and numbers == others
    assert a["largest"] == b["largest"]


@pytest.mark.filterwarnings("ignore:the surface's triangles under the probe")
@pytest.mark.parametrize("method, material", [(method, "linear") for method in METHODS]
                         + [("fem", "neo-hookean"), ("hybrid", "neo-hookean"), ("embedded", "corotated")])
def test_a_press_that_does_not_converge_changes_nothing(small_cube, method, material):
    solver, probe = pressed(small_cube, method, material=material)
    twin, _ = pressed(small_cube, method, material=material)
    before = state(solver, probe)
    with pytest.raises(SolverError, match=r"did not converge in 1 iterations .*nothing was changed"):
        probe.press_static([0.0, 0.0, TOP + RADIUS - 0.6 * RADIUS], max_iterations=1)
    assert_same(state(solver, probe), before)
    for _ in range(3):       # the probe's loads of the refused press do not push on
        solver.step()
        twin.step()
    assert np.abs(solver.positions - twin.positions).max() <= SAME
    assert np.abs(solver.velocities - twin.velocities).max() <= SAME / solver.dt


@pytest.mark.filterwarnings("ignore:the surface's triangles under the probe")
@pytest.mark.parametrize("method", METHODS)
def test_a_press_the_solver_cannot_carry_changes_nothing(small_cube, method, monkeypatch):
    # the solver refuses the third iteration's forces after it moved (as a finite-strain solve with no stable
    # equilibrium or a blow-up does): its error is raised, and the probe is no longer withdrawn with the state left
    # where the iterations took it
    solver, probe = pressed(small_cube, method)
    twin, _ = pressed(small_cube, method)
    before = state(solver, probe)
    solve, calls = solver.solve_static, []

    def refusing(**options):
        calls.append(solve(**options))
        if len(calls) == 3:
            raise SolverError("no stable equilibrium under these forces")
        return calls[-1]

    monkeypatch.setattr(solver, "solve_static", refusing)
    with pytest.raises(SolverError, match=r"no stable equilibrium"):
        probe.press_static([0.0, 0.0, TOP + RADIUS - 0.6 * RADIUS])
    assert not np.array_equal(calls[-1], before["positions"])      # it had moved
    assert_same(state(solver, probe), before)
    solver.step()
    twin.step()
    assert np.abs(solver.positions - twin.positions).max() <= SAME
