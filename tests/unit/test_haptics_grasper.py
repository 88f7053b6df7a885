"""The haptic loop holding a grasper: a simulated hand pulls the jaws through the virtual coupling; once it settles,
the force the device feels is the static grasper's reaction with its jaws where the coupling puts them. The loop
with a free device mass keeps its energy at 1 kHz, and refused grabs change nothing."""

import numpy as np
import pytest
from test_haptics import TICK, Hand, settle, top_centre

from tissuesim import BoundaryConditionError, Grasper, HybridMesh, SolverError, make_solver
from tissuesim.haptics import HapticLoop, HapticProcess
from tissuesim.solvers import method_names

JAWS = 0.008  # m: the jaws' reach; 9 vertices of the cube's top
COUPLING = 200.0  # N/m: stiffer than the held patch (about 50–200 N/m)
FRAME = 1.0 / 60.0  # s: the visual loop's rate


@pytest.fixture(scope="module")
def cube():
    from tissuesim.mesh import models

    return HybridMesh.build(models.cube(), fine_volume=True)


def grasper_loop(solver, hand):
    return HapticLoop(solver, position=hand.position, apply_force=hand.apply_force, stiffness=COUPLING,
                      radius=JAWS, tool="grasper")


def jaws_for(loop, force):
    """x_j = x0 + C_g f: where the coupling puts the jaws under ``force`` ``(3,)`` [N]."""
    return loop.response.origin + loop.response.compliance @ force


@pytest.mark.parametrize("method, agreement", [("fem", 1e-9), ("hybrid", 1e-3)])
def test_the_settled_force_is_the_static_graspers_reaction(cube, method, agreement):
    solver = make_solver(method, cube)
    node = top_centre(cube)
    start = cube.surface.vertices[node]
    hand = Hand(start, start + [0.002, -0.002, 0.006])
    loop = grasper_loop(solver, hand)
    assert loop.grab() == node and node in loop.grasper.held
    assert loop.grasper.held.size >= 7 and np.array_equal(loop.tick(), np.zeros(3))  # grabbing pulls nothing
    assert np.allclose(loop.response.origin, start, rtol=0, atol=1e-12)  # at rest the jaws hold no force
    force = settle(loop, hand)
    jaws = jaws_for(loop, force)
    assert np.linalg.norm(jaws - start) > 1.5e-3  # a real pull, millimetres
    assert np.array_equal(loop.sync(), force)
    while not loop.grasper.settle():  # the visual loop's frames until the jaws are there
        pass
    assert np.array_equal(loop.grasper.position, jaws)
    # the same jaws on a twin solver, moved there by the grasper's static solve
    static = Grasper(make_solver(method, cube), radius=JAWS, tolerance=1e-12 if method == "fem" else None)
    assert np.array_equal(static.grab(start), loop.grasper.held)
    reaction = static.move_to(jaws)
    # fem: exact (its compliance is the grasper's Jacobian); hybrid: to the grasper's tolerance (8 µm)
    assert np.linalg.norm(-reaction - force) <= agreement * np.linalg.norm(force)
    assert np.linalg.norm(loop.grasper.force - reaction) <= agreement * np.linalg.norm(force)
    assert force[2] > 0.0 and hand.force[2] < 0.0  # the tissue is lifted and pulls the hand down


class FreeHand(Hand):
    """The device's mass (0.1 kg) on the coupling alone: no hand spring, no damping, so nothing but the loop can
    change its energy."""

    stiffness, damping = 0.0, 0.0


@pytest.mark.parametrize("method", method_names(where=lambda cls: hasattr(cls, "point_compliance")))
def test_a_free_device_mass_keeps_its_energy_at_1khz(cube, method):
    solver = make_solver(method, cube)
    node = top_centre(cube)
    hand = FreeHand(cube.surface.vertices[node], cube.surface.vertices[node])
    loop = grasper_loop(solver, hand)
    loop.grab(node)
    release = np.array([0.002, 0.001, 0.004])
    hand.tool = hand.tool + release  # let go of the device 4.6 mm from the coupling's rest
    anchor = loop.response.origin + loop.offset
    gain = np.linalg.solve(np.eye(3) + COUPLING * loop.response.compliance, COUPLING * np.eye(3))
    symmetric = 0.5 * (gain + gain.T)
    energies = []
    for tick in range(3000):  # 3 s, the visual loop syncing (the jaws settling) at 60 Hz
        loop.tick()
        hand.advance(TICK)
        stretch = hand.tool - anchor
        energies.append(0.5 * hand.mass * hand.velocity @ hand.velocity + 0.5 * stretch @ symmetric @ stretch)
        if tick % round(FRAME / TICK) == 0:
            loop.sync()
    energies = np.array(energies)
    # semi-implicit Euler keeps a modified energy: the sampled one wobbles by about ω dt (ω ≤ 45 rad/s), and
    # neither grows nor decays from the first second to the last
    assert np.ptp(energies) <= 0.05 * energies[0]
    assert energies[-1000:].max() <= energies[:1000].max() * (1.0 + 1e-3)
    # the jaws followed the device (measured 0.4 mm on the embedded surface, the stiffest; over 1 mm elsewhere)
    assert np.linalg.norm(loop.grasper.position - loop.response.origin) > 0.05 * np.linalg.norm(release)


def test_refusals_change_nothing(cube):
    solver = make_solver("fem", cube)
    node = top_centre(cube)
    hand = Hand(cube.surface.vertices[node], cube.surface.vertices[node])
    ok = dict(position=hand.position, apply_force=hand.apply_force, stiffness=COUPLING)
    with pytest.raises(SolverError, match="reach"):
        HapticLoop(solver, **ok, tool="grasper")
    with pytest.raises(SolverError, match="unknown haptic tool"):
        HapticLoop(solver, **ok, radius=JAWS, tool="forceps")
    with pytest.raises(SolverError, match="reach"):
        HapticProcess(solver, device=Hand, stiffness=COUPLING, tool="grasper")
    loop = grasper_loop(solver, hand)
    before = solver.positions.copy()
    fixed = int(solver.fixed[0])
    x = solver.rest_positions
    free = np.setdiff1d(np.arange(len(x)), solver.fixed)
    near = np.linalg.norm(x[free, None] - x[None, solver.fixed], axis=2).min(axis=1)
    beside = int(free[np.argmax(near < JAWS)])  # free, with a fixed vertex within the jaws' reach
    for bad, error in ((fixed, BoundaryConditionError), (beside, BoundaryConditionError),
                       (solver.node_count, SolverError), (-1, SolverError)):
        with pytest.raises(error, match="fixed" if error is BoundaryConditionError else "vertices 0"):
            loop.grab(bad)
        assert loop.response is None and not loop.grasper.holding and len(solver.loads) == 0
        assert np.array_equal(solver.positions, before)
    # holding a patch, a refused grab keeps it: the coupling, the jaws and their forces
    loop.grab(node)
    hand.tool = hand.tool + [0.0, 0.0, 0.003]
    pulled = loop.tick().copy()
    loop.sync()
    held, response, positions = loop.grasper.held.copy(), loop.response, solver.positions.copy()
    forces = [load.force.copy() for load in solver.loads]
    with pytest.raises(BoundaryConditionError):
        loop.grab(beside)
    assert loop.response is response and np.array_equal(loop.grasper.held, held)
    assert np.array_equal(solver.positions, positions)
    assert all(np.array_equal(load.force, force) for load, force in zip(solver.loads, forces))
    assert np.array_equal(loop.tick(), pulled)
    loop.release()
    assert not loop.grasper.holding and len(solver.loads) == 0 and np.array_equal(loop.tick(), np.zeros(3))


@pytest.mark.slow
def test_finite_strain_settles_at_the_static_graspers_reaction(cube):
    """Neo-Hookean: the coupling's C_g is the tangent at the grab; after two syncs (each measures it again where
    the jaws settled) the settled force is the static grasper's reaction at the jaws' place."""
    solver = make_solver("fem", cube, material="neo-hookean")
    node = top_centre(cube)
    start = cube.surface.vertices[node]
    hand = Hand(start, start + [0.002, 0.0, 0.006])
    loop = grasper_loop(solver, hand)
    loop.grab(node)
    for _ in range(2):
        settle(loop, hand)
        loop.sync()
    force = settle(loop, hand)
    static = Grasper(make_solver("fem", cube, material="neo-hookean"), radius=JAWS, tolerance=1e-9)
    static.grab(start)
    reaction = static.move_to(jaws_for(loop, force))
    assert np.linalg.norm(-reaction - force) <= 1e-3 * np.linalg.norm(force)
