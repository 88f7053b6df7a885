"""The solver API takes numbers, not text: a string (or bytes, a bool, None, a complex) where a number is due is
refused with a message naming the argument, its unit and the fix, as scene files refuse them, and the refusal
changes nothing."""

import numpy as np
import pytest

from tissuesim import PinHead, make_solver
from tissuesim.errors import MaterialError, SolverError
from tissuesim.loads import contact_radius
from tissuesim.solvers.checks import check_force, checked_point, positive_number, time_step


@pytest.fixture(scope="module")
def loaded(small_cube, small_cube_top):
    """A pbd solver a few steps under 1 N on the top node."""
    solver = make_solver("pbd", small_cube)
    solver.set_load(small_cube_top, [0.0, 0.0, 1.0])
    for _ in range(3):
        solver.step()
    return solver


def _unchanged(solver, before):
    positions, velocities, forces = before
    return (np.array_equal(solver.positions, positions) and np.array_equal(solver.velocities, velocities)
            and np.array_equal(solver.forces, forces))


def _state(solver):
    return solver.positions.copy(), solver.velocities.copy(), solver.forces.copy()


@pytest.mark.parametrize("dt", ["0.01", b"0.01", np.str_("0.01"), "nan"])
def test_step_refuses_a_time_step_given_as_text(loaded, dt):
    before = _state(loaded)
    with pytest.raises(SolverError, match=r"time step dt must be a number \[s\].*pass a number, e.g. 0.01"):
        loaded.step(dt)
    assert _unchanged(loaded, before)


def test_the_dt_option_refuses_text(small_cube):
    with pytest.raises(SolverError, match=r"time step dt must be a number \[s\], got '0.001'"):
        make_solver("pbd", small_cube, dt="0.001")


@pytest.mark.parametrize("force", [("0", "0", "-1"), "0 0 -1", [0.0, 0.0, b"1"], [0.0, 0.0, None],
                                   [True, False, True], [0.0, 0.0, 1j]])
def test_solve_static_refuses_a_force_that_is_not_numbers(loaded, small_cube_top, force):
    before = _state(loaded)
    with pytest.raises(SolverError, match=r"force must be 3 numbers \[N\].*e.g. \[0, 0, -1\]"):
        loaded.solve_static(small_cube_top, force)
    assert _unchanged(loaded, before)


@pytest.mark.parametrize("call", ["set_load", "add_load"])
def test_loads_refuse_text_forces_and_radii(loaded, small_cube_top, call):
    before = _state(loaded)
    with pytest.raises(SolverError, match=r"force must be 3 numbers \[N\]"):
        getattr(loaded, call)(small_cube_top, ["0", "0", "1"])
    with pytest.raises(SolverError, match=r"contact radius must be a number \[m\] or None, got '0.004'.*e.g. 0.004"):
        getattr(loaded, call)(small_cube_top, [0.0, 0.0, 1.0], radius="0.004")
    assert _unchanged(loaded, before)


@pytest.mark.parametrize("option, value", [("tolerance", "1e-6"), ("rtol", "1e-5"), ("dt", "0.01")])
def test_solve_static_refuses_text_options(loaded, small_cube_top, option, value):
    before = _state(loaded)
    with pytest.raises(SolverError, match=rf"must be a number .*got '{value}'"):
        loaded.solve_static(small_cube_top, [0.0, 0.0, 1.0], **{option: value})
    assert _unchanged(loaded, before)


def test_pin_head_refuses_a_stiffness_given_as_text(loaded):
    with pytest.raises(SolverError, match=r"pin-head stiffness must be a number \[N/m\], got '20'.*e.g. 20"):
        PinHead(loaded, stiffness="20")


@pytest.mark.parametrize("gravity", [("0", "0", "-9.81"), "0 0 -9.81", [0, 0, b"-9.81"], [False, False, True]])
def test_gravity_given_as_text_is_refused(small_cube, gravity):
    with pytest.raises(SolverError, match=r"gravity .*3 finite numbers.*e.g. \(0, 0, -9.81\)"):
        make_solver("hybrid", small_cube, gravity=gravity)


@pytest.mark.parametrize("option, value, unit", [("density", "1000", "kg/m³"), ("damping", "0.1", "1")])
def test_solver_options_refuse_text(small_cube, option, value, unit):
    with pytest.raises(SolverError, match=rf"{option} must be a number \[{unit}\], got '{value}'"):
        make_solver("pbd", small_cube, **{option: value})


@pytest.mark.parametrize("value", [None, [0.01], np.array([0.01]), 1j, object()])
def test_other_non_numbers_are_refused_by_the_scalar_checks(value):
    with pytest.raises(SolverError, match=r"must be a number \[m\]"):
        positive_number("length", value, "m")
    with pytest.raises(SolverError, match=r"must be a number \[m\]"):
        contact_radius(value)


def test_a_point_given_as_text_is_refused():
    with pytest.raises(SolverError, match=r"the probe centre must be 3 numbers \[m\]"):
        checked_point(["0", "0", "0.1"], name="the probe centre")


@pytest.mark.parametrize("value, expected", [(0.01, 0.01), (np.float32(0.5), 0.5), (np.int64(2), 2.0),
                                             (np.array(0.25), 0.25), (3, 3.0)])
def test_numbers_of_every_numeric_type_are_taken(value, expected):
    assert time_step(value) == pytest.approx(expected, rel=1e-7)
    assert contact_radius(value) == pytest.approx(expected, rel=1e-7)


def test_numeric_arrays_of_every_numeric_type_are_taken():
    for force in ([0, 0, -1], np.array([0, 0, -1], dtype=np.int32), np.array([0.0, 0.0, -1.0], dtype=np.float32),
                  (np.float64(0.0), 0, np.int8(-1))):
        assert np.array_equal(check_force(force), [0.0, 0.0, -1.0])


@pytest.mark.parametrize("option, value", [("youngs_modulus", "5500"), ("poisson_ratio", "0.3"),
                                           ("youngs_modulus", b"5500")])
def test_the_material_refuses_text(small_cube, option, value):
    with pytest.raises(MaterialError, match=rf"{option} must be a real number, got {value!r}; pass a number"):
        make_solver("pbd", small_cube, **{option: value})


def test_the_paper_pbd_forms_stiffness_refuses_text(small_cube):
    with pytest.raises(SolverError, match=r"stiffness must be a number \[1\], got '0.5'; pass a number, e.g. 0.5"):
        make_solver("pbd", small_cube, form="pbd", stiffness="0.5")
