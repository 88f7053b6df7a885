"""What a finite-strain answer says about itself: its own range (not linear elasticity's), a collapse under a load with
no stable equilibrium, and no load never called an unstable one."""

import numpy as np
import pytest

from tissuesim import Probe, Scalpel, make_solver
from tissuesim.errors import SolverError
from tissuesim.fem.nonlinear import NonlinearFEM, UnstableLoadError
from tissuesim.solvers import method_names

FINITE_MATERIALS = ("corotated", "neo-hookean")
#: the methods that take both finite-strain materials
FINITE_STRAIN = method_names(where=lambda cls: set(FINITE_MATERIALS) <= set(cls.materials))


def _turned_base(solver, degrees=90.0):
    """The solver's rest surface turned by ``degrees`` about x through its centre."""
    rest = solver.rest_positions
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    centre = rest.mean(axis=0)
    return (rest - centre) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]]).T + centre


@pytest.mark.parametrize("method", FINITE_STRAIN)
@pytest.mark.parametrize("material", FINITE_MATERIALS)
def test_a_turned_finite_strain_body_is_not_called_beyond_linear_elasticity(small_cube, small_cube_top, method,
                                                                             material):
    """A body turned a quarter turn with its base moves by about its size and is not strained at all."""
    solver = make_solver(method, small_cube, material=material)
    solver.set_fixed_positions(_turned_base(solver)[solver.fixed])
    solver.solve_static(small_cube_top, (0.0, 0.0, 0.0), reset=False)
    assert solver.largest_displacement > 0.5 * solver.size
    assert solver.last_solve.warning is None and solver.warning is None
    assert solver.last_solve.crushed == 0 and solver.last_solve.smallest_volume_ratio == pytest.approx(1.0, abs=1e-9)


def test_a_finite_strain_answer_with_crushed_elements_warns_of_the_materials_range(small_cube, small_cube_top):
    solver = make_solver("fem", small_cube, material="neo-hookean")
    solver.solve_static(small_cube_top, (1.5, 0.0, 0.0), radius=0.004)
    report = solver.last_solve
    assert 0.1 < report.smallest_volume_ratio < 0.5 and report.crushed >= 1
    for warning in (report.warning, solver.warning):
        assert "neo-hookean material is beyond its range" in warning and "crushed below 0.5" in warning
        assert "linear elasticity" not in warning and "Probe" in warning
    linear = make_solver("fem", small_cube)
    linear.solve_static(small_cube_top, (30.0, 0.0, 0.0), radius=0.004)
    assert "linear elasticity is not valid here" in linear.last_solve.warning


def test_a_lateral_dead_load_that_crushes_the_surface_ahead_of_its_tip_says_it_has_no_stable_equilibrium(
        small_cube, small_cube_top):
    """3 N sideways on a 4 mm tip: the fine volume's Newton converges on elements crushed flat (J = 0.016) and the
    answer came back without a word."""
    solver = make_solver("fem", small_cube, material="neo-hookean")
    solver.solve_static(small_cube_top, (3.0, 0.0, 0.0), radius=0.004)
    assert solver.last_solve.smallest_volume_ratio < 0.1
    for warning in (solver.last_solve.warning, solver.warning):
        assert "neo-hookean body collapses under this load" in warning and "no stable equilibrium" in warning
        assert "wider tip" in warning and "Probe" in warning


def test_a_finite_strain_failure_under_no_load_names_what_acts_not_a_dead_load(small_cube, monkeypatch):
    solver = make_solver("embedded", small_cube, material="corotated", gravity=(0.0, 0.0, -9.81))
    solver.set_fixed_positions(solver.rest_positions[solver.fixed] + [0.0, 0.002, 0.0])

    def no_equilibrium(self, forces, **options):
        raise UnstableLoadError("no stable equilibrium", reached=0.25)

    monkeypatch.setattr(NonlinearFEM, "solve", no_equilibrium)
    with pytest.raises(SolverError) as refused:
        solver.step()
    message = str(refused.value)
    assert "with no load acting" in message and "weight (g = 9.81 m/s²)" in message
    assert "motion of its base" in message and "25 % of it was carried" in message
    assert "dead load" not in message and "inf" not in message and " 0 N" not in message


def test_a_probe_pressing_after_a_cut_reaches_its_contact_on_the_finite_strain_embedded_body(small_cube):
    """The probe's iterations withdraw every load on the way; the warm start they leave behind is tangled, and the
    solve under no load was refused as "a dead load of 0 N on 0 node(s) ... inf μ"."""
    solver = make_solver("embedded", small_cube, material="neo-hookean")
    scalpel = Scalpel(solver, depth=0.01)
    scalpel.press([-0.02, 0.0, 0.08])
    scalpel.move([0.02, 0.0, 0.08])
    scalpel.release()
    probe = Probe(solver, radius=0.008)
    with pytest.warns(UserWarning, match="sink"):
        probe.press_static([0.0, 0.0, 0.084])
    assert probe.residual <= probe.tolerance
    assert 0.5 < probe.force[2] < 2.0       # the tissue pushes the probe up, by about a newton
