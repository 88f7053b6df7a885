"""Every method answers as an elastic body (DESIGN "physics first"), checked where it can fail: on the *stepped* path.

A static solve never reads dt, the node masses or the sweep count, and a linear solve is linear in the load and
scales as 1/E by construction, so those are not tested on it. What can fail is the time stepping: under a constant
load, ``step`` must come to rest at the same state for every dt, density, iteration count and stiffness at fixed
strain (E × 10 and the load × 10), and for the linear methods that state is the static answer. The load is a
pin-head contact (radius 8 mm) on the top of a small cube, as in the contact protocol; ``hybrid-near`` is the hybrid
with its near field. The paper's own PBD form (``form="pbd"``) is left out: its equilibrium is documented to move with
dt and the masses (docs/solvers.md).

The mass-spring baseline is stepped on the sphere: springs alone hold a flat patch against a normal load only through
the tension the load itself builds, so on the cube's top it settles slowly (the slow run checks it there too).

Tolerance: a run is at rest when one step moves no node by more than 1e-12 of the largest displacement (1e-9 for
the explicit mass-spring step, whose round-off floor is ~2e-11). The decay is not a clean geometric tail (damped
modes beat: the per-step ratio swings between 0.4 and 0.98), so no extrapolation is trusted. There the implicit runs
sit on their fixed point (measured ≤ 9e-11 off the static answer) and the mass-spring runs within ~1e-9 of each
other; two rests of the same equilibrium must agree to 1e-6 (relative to the largest displacement, max over nodes),
while a rest state that moves with dt or the masses is off by 1e-2 or more.
"""

import numpy as np
import pytest

from tissuesim import HybridMesh, make_solver
from tissuesim.experiments.contact_protocol import VARIANTS
from tissuesim.experiments.protocol import load_node
from tissuesim.mesh import models
from tissuesim.solvers import method_names
from tissuesim.solvers.surface_layer import SurfaceLayerSolver

RADIUS = 0.008  # m
#: Small load: the largest displacement stays below 2 % of the cube's 6 cm (checked below).
FORCE = np.array([0.0, 0.0, -0.05])  # N
REST = 1e-12       # at rest: a step moves no node by more than this fraction of the largest displacement
#: The explicit mass-spring step's round-off floor is ~2e-11 of its displacement: rest at fifty times that.
SPRING_REST = 1e-9
AGREE = 1e-6       # two rests of one equilibrium agree to this fraction (module docstring)
MAX_STEPS = 5000
#: Variants of the stepped run that must not move its rest state (E × 10 goes with the load × 10: same strain).
VARIANTS_OF_STEP = {"dt 2.5 ms": {"dt": 0.0025}, "dt 20 ms": {"dt": 0.02}, "density x0.1": {"density": 100.0},
                    "density x10": {"density": 10000.0}, "E x10 at fixed strain": {"youngs_modulus": 55000.0}}
#: Stepped by the implicit integrator to the static answer (and the hybrid's near-field variant).
LINEAR = [*method_names(where=lambda cls: not cls.static_by_default() and cls.solves_statics()), "hybrid-near"]
STATIC_METHODS = [*method_names(where=lambda cls: cls.solves_statics()), "hybrid-near"]
LAYER = method_names(where=lambda cls: issubclass(cls, SurfaceLayerSolver))     # the surface-layer methods


@pytest.fixture(scope="module")
def cube():
    return HybridMesh.build(models.cube(resolution=386), fine_volume=True)


@pytest.fixture(scope="module")
def sphere():
    return HybridMesh.build(models.sphere(resolution=386), fine_volume=False)


def solver_for(mesh, method, **options):
    name, variant = VARIANTS.get(method, (method, {}))
    return make_solver(name, mesh, **variant, **options)


def static_displacement(mesh, method, *, force=FORCE, **options) -> np.ndarray:
    """``(n, 3)`` quasi-static displacements [m] of ``method`` under ``force`` [N] on the contact patch."""
    solver = solver_for(mesh, method, **options)
    node = load_node(mesh.surface.vertices, mesh.surface.triangles)
    return solver.solve_static(node, force, radius=RADIUS) - mesh.surface.vertices


def rest_displacement(mesh, method, *, force=FORCE, max_steps=MAX_STEPS, rest=REST, **options) -> np.ndarray:
    """``(n, 3)`` displacements [m] where ``step`` comes to rest under a constant ``force`` [N] (module docstring);
    E × k in ``options`` goes with ``force`` × k (the same strain, so the same displacements)."""
    scale = options.get("youngs_modulus", 5500.0) / 5500.0
    solver = solver_for(mesh, method, **options)
    node = load_node(mesh.surface.vertices, mesh.surface.triangles)
    solver.set_load(node, force * scale, radius=RADIUS)
    previous = solver.positions.copy()
    for _ in range(max_steps):
        solver.step()
        motion = np.abs(solver.positions - previous).max()
        previous[:] = solver.positions
        if motion <= rest * np.abs(solver.positions - mesh.surface.vertices).max():
            return solver.positions - mesh.surface.vertices
    pytest.fail(f"{method} {options} did not come to rest within {max_steps} steps (last step moved {motion:.3g} m)")


def off(u, v) -> float:
    """Largest node difference of ``u`` from ``v``, relative to ``v``'s largest displacement."""
    return float(np.abs(u - v).max() / np.abs(v).max())


@pytest.fixture(scope="module")
def static(cube):
    return {method: static_displacement(cube, method) for method in STATIC_METHODS}


# ------------------------------------------------------------------------------------ static answers that can fail
@pytest.mark.parametrize("method", STATIC_METHODS)
def test_load_is_small_and_the_static_answer_moves(static, method):
    largest = np.linalg.norm(static[method], axis=1).max()
    assert 1e-6 < largest < 0.02 * 0.06


@pytest.mark.parametrize("method", STATIC_METHODS)
def test_equilibrium_responds_to_poisson_ratio(cube, static, method):
    assert off(static_displacement(cube, method, poisson_ratio=0.45), static[method]) > 0.01


# ------------------------------------------------------------------------------- the stepped path: linear methods
@pytest.mark.parametrize("method", STATIC_METHODS)
def test_stepping_comes_to_rest_at_the_static_answer(cube, static, method):
    assert off(rest_displacement(cube, method), static[method]) < AGREE


@pytest.mark.parametrize("options", VARIANTS_OF_STEP.values(), ids=VARIANTS_OF_STEP.keys())
@pytest.mark.parametrize("method", LINEAR)
def test_rest_state_does_not_move_with_dt_mass_or_stiffness_at_fixed_strain(cube, static, method, options):
    assert off(rest_displacement(cube, method, **options), static[method]) < AGREE


# ------------------------------------------------------------ the stepped path: nonlinear ones (mass-spring, XPBD)
@pytest.fixture(scope="module")
def spring_rest(sphere):
    return rest_displacement(sphere, "mass-spring", force=np.array([0.0, 0.0, -0.02]), rest=SPRING_REST)


@pytest.mark.parametrize("options", VARIANTS_OF_STEP.values(), ids=VARIANTS_OF_STEP.keys())
def test_mass_spring_rest_state_does_not_move_with_dt_mass_or_stiffness(sphere, spring_rest, options):
    assert np.abs(spring_rest).max() > 1e-6
    u = rest_displacement(sphere, "mass-spring", force=np.array([0.0, 0.0, -0.02]), rest=SPRING_REST, **options)
    assert off(u, spring_rest) < AGREE


@pytest.mark.slow
@pytest.mark.parametrize("options", [{"dt": 0.0025}, {"density": 10000.0}], ids=["dt 2.5 ms", "density x10"])
def test_mass_spring_rest_state_on_the_flat_top_does_not_move_with_dt_or_mass(cube, options):
    """The springs' nonlinear regime (u ~ f^(1/3) on a flat patch): 5000-8000 steps to rest at these settings."""
    u = rest_displacement(cube, "mass-spring", max_steps=20000, rest=SPRING_REST)
    assert off(rest_displacement(cube, "mass-spring", max_steps=20000, rest=SPRING_REST, **options), u) < AGREE


#: Measured on this cube, 0.05 N: the hybrid's XPBD rest moves by 0.19-0.97 of its displacement with dt, density,
#: E at fixed strain or the sweeps, and rests 0.21 off the static answer at the defaults; pbd's moves by 0.8-6.9x and
#: rests at 15x the static answer (1.28 mm against 0.085 mm). E and the masses enter only as E dt^2 / m. Converging
#: the projection every step (to 1e-10 of the multipliers) removes the sweeps' effect but not dt's or the masses':
#: the hybrid's rest then moves by 0.19-0.44 of its displacement (0.21 off the static answer) at 70-6,653 sweeps and
#: 4-390 ms a step, and pbd does not converge within 20,000 sweeps (1.1 s a step): the step drops XPBD's primal
#: residual, so the solver warns when this integrator is chosen (docs/solvers.md).
XPBD_REASON = ("the XPBD projection (multipliers reset each step, a fixed number of sweeps) rests at a state that "
               "moves with dt, the masses, E at fixed strain and the sweeps, and converging it every step leaves "
               "0.19-0.44 of the displacement with dt and the masses (docs/solvers.md): a defect of that "
               "integrator, which warns when chosen; the default implicit one rests at the static answer")


@pytest.mark.xfail(strict=True, raises=AssertionError, reason=XPBD_REASON)
@pytest.mark.parametrize("options", [*VARIANTS_OF_STEP.values(), {"iterations": 2}, {"iterations": 40}],
                         ids=[*VARIANTS_OF_STEP.keys(), "2 sweeps", "40 sweeps"])
@pytest.mark.parametrize("method", LAYER)
def test_xpbd_integrator_rest_state_does_not_move_with_dt_mass_or_sweeps(cube, method, options):
    u = rest_displacement(cube, method, integrator="xpbd")
    assert off(rest_displacement(cube, method, integrator="xpbd", **options), u) < AGREE
