"""The XPBD integrator says, when chosen, that it does not rest at the layer's elastic equilibrium.

Its rest state moves with dt, the masses, E at fixed strain and the sweep count (the strict xfails of
tests/validation/test_physical_consistency.py), and converging its projection every step does not cure that (the
step drops XPBD's primal residual; docs/solvers.md). A user who picks it must not take its answers for the body's.
"""

import warnings

import pytest

import tissuesim
from tissuesim.errors import TissuesimWarning
from tissuesim.mesh import models
from tissuesim.solvers import method_names
from tissuesim.solvers.surface_layer import SurfaceLayerSolver

#: the methods with a surface layer: the layer's projection takes the integrator option
SURFACE_LAYER = method_names(where=lambda cls: issubclass(cls, SurfaceLayerSolver))


@pytest.fixture(scope="module")
def cube():
    return tissuesim.HybridMesh.build(models.cube(), fine_volume=False)


@pytest.mark.parametrize("method", SURFACE_LAYER)
def test_choosing_the_xpbd_integrator_warns_that_it_does_not_rest_at_the_equilibrium(cube, method):
    with pytest.warns(TissuesimWarning, match=r"integrator='xpbd' does not rest at the layer's elastic equilibrium.*"
                                              r"integrator='implicit' for answers"):
        tissuesim.make_solver(method, cube, integrator="xpbd")


@pytest.mark.parametrize("method,options", [("hybrid", {}), ("pbd", {}), ("hybrid", {"form": "pbd"})])
def test_the_integrators_that_rest_at_their_equilibrium_do_not_warn(cube, method, options):
    with warnings.catch_warnings():
        warnings.simplefilter("error", TissuesimWarning)
        tissuesim.make_solver(method, cube, **options)


def test_the_warnings_point_at_the_users_line_not_inside_the_package(cube):
    with pytest.warns(TissuesimWarning) as caught:
        tissuesim.make_solver("pbd", cube, integrator="xpbd")
        tissuesim.make_solver("embedded", cube, poisson_ratio=0.47)      # linear tets lock: a warning too
    assert len(caught) >= 2 and {w.filename for w in caught} == {__file__}, [(w.filename, w.lineno) for w in caught]
