"""Gravity where it is the cause: absurd gravity is refused where it is given (the API and a scene file, before the
mesh is built), and a mass-spring surface that turns inside out under its own weight says that gravity did it."""

import warnings

import numpy as np
import pytest

from tissuesim import make_solver
from tissuesim.errors import InversionError, SolverError
from tissuesim.scene import SceneError, read_scene
from tissuesim.scene.build import check_method
from tissuesim.solvers import available_solvers
from tissuesim.solvers.checks import MAX_GRAVITY, gravity_vector

METHODS = available_solvers()


@pytest.mark.parametrize("gravity", [(0.0, 0.0, -1e30), (0.0, 0.0, -1.0001 * MAX_GRAVITY), (1e200, 1e200, 0.0),
                                     (-9e3, 0.0, -9e3)])
def test_absurd_gravity_is_refused_where_it_is_given(small_cube, gravity):
    with pytest.raises(SolverError) as error:
        make_solver("pbd", small_cube, gravity=gravity)
    message = str(error.value)
    assert f"is beyond {MAX_GRAVITY:g} m/s²" in message and "e.g. (0, 0, -9.81)" in message
    assert "dt" not in message and "load" not in message and "pin-head" not in message


@pytest.mark.parametrize("method", METHODS)
def test_every_method_refuses_gravity_of_1e30(small_cube, method):
    with pytest.raises(SolverError, match="gravity of 1e[+]30 m/s²"):
        make_solver(method, small_cube, gravity=(0.0, 0.0, -1e30))


@pytest.mark.parametrize("gravity", [(0.0, 0.0, -9.81), (0.0, 0.0, -MAX_GRAVITY), (0.0, 0.0, 0.0)])
def test_gravity_up_to_the_bound_is_taken(gravity):
    assert np.array_equal(gravity_vector(gravity), gravity)


def test_a_scene_with_absurd_gravity_is_refused_before_its_mesh_is_built(tmp_path):
    scene = tmp_path / "heavy.toml"
    scene.write_text('gravity = [0.0, 0.0, -1e30]\n[model]\nname = "cube"\n[method]\nname = "hybrid"\n')
    with pytest.raises(SceneError, match=r"heavy.toml: gravity: gravity of 1e\+30 m/s² .* is beyond"):
        check_method(read_scene(scene))


def test_mass_spring_inverted_by_its_weight_alone_names_gravity(small_cube):
    """At 1,000 g₀ the cube's mass-spring surface turns inside out in its first step, under no load at all."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")      # the mass-spring method's caveat on gravity
        solver = make_solver("mass-spring", small_cube, gravity=(0.0, 0.0, -9810.0))
    with pytest.raises(InversionError) as error:
        solver.step()
    message = str(error.value)
    assert "under its own weight (gravity 9810 m/s², no load)" in message
    assert "0 N" not in message and "lower the force" not in message
    assert "lower gravity" in message and "hybrid, embedded or fem" in message
