"""The haptic loop: a simulated hand (a mass on a spring pulled toward a target) holds the tissue through the loop's
virtual coupling; once it settles, the force the loop exchanges and where it puts the node match the full solver's
static answer. Refusals, the visual state left as it was, and the thread's bookkeeping (never its timing)."""

import threading
import time

import numpy as np
import pytest

from tissuesim import BoundaryConditionError, HybridMesh, SolverError, TissuesimError, make_solver
from tissuesim.haptics import HapticLoop, HapticProcess, local_response
from tissuesim.haptics.process import REPORT
from tissuesim.mesh import models

RADIUS = 0.004  # m: the pin-head's tip
COUPLING = 200.0  # N/m: stiffer than the cube's top under this tip (about 25–70 N/m)
TICK = 1e-3  # s: the hand is integrated at the loop's 1 kHz


@pytest.fixture(scope="module")
def cube():
    return HybridMesh.build(models.cube(), fine_volume=False)


def top_centre(hybrid, shift=(0.0, 0.0, 0.0)) -> int:
    """The M_S node nearest the centre of the top face moved by ``shift`` [m]."""
    x = hybrid.surface.vertices
    centre = x.mean(axis=0)
    centre[2] = x[:, 2].max()
    return int(np.argmin(np.linalg.norm(x - centre - shift, axis=1)))


class Hand:
    """A hand of mass 0.1 kg pulled toward ``target`` by a 50 N/m spring (critically damped with the coupling),
    holding the tool; semi-implicit Euler at 1 kHz."""

    mass, stiffness, damping = 0.1, 50.0, 6.0

    def __init__(self, start, target):
        self.tool = np.array(start, dtype=float)
        self.velocity = np.zeros(3)
        self.target = np.array(target, dtype=float)
        self.force = np.zeros(3)  # what the device renders [N]

    def position(self):
        return self.tool

    def apply_force(self, force):
        self.force[:] = force

    def advance(self, dt):
        pull = self.stiffness * (self.target - self.tool) - self.damping * self.velocity + self.force
        self.velocity += pull / self.mass * dt
        self.tool = self.tool + self.velocity * dt


def settle(loop, hand, ticks=3000):
    for _ in range(ticks):
        loop.tick()
        hand.advance(TICK)
    assert np.linalg.norm(hand.velocity) < 1e-8  # settled: the comparison below is at equilibrium
    return loop.tick().copy()


def check_against_full_solver(loop, hand, reference, node):
    """The settled force f and the node's place x = p − a − f / k_c against the full solver loaded with f."""
    force = loop.tick().copy()
    assert np.allclose(-hand.force, force, rtol=1e-12, atol=0)  # the device got −f
    # the hand at rest: its spring balances the force it feels (to its settling residue, 1e-8 m/s above)
    assert np.linalg.norm(hand.stiffness * (hand.target - hand.tool) - force) < 1e-6 * np.linalg.norm(force)
    coupled = hand.tool - loop.offset - force / COUPLING
    full = reference.solve_static(node, force, radius=RADIUS)[node]
    moved = np.linalg.norm(coupled - reference.rest_positions[node])
    assert moved > 1e-3  # a real pull, several millimetres
    # the target's 2 %: where the full solver puts the node under f, and the force it needs to put it there
    assert np.linalg.norm(full - coupled) < 0.02 * moved
    needed = COUPLING * (hand.tool - loop.offset - full)
    assert np.linalg.norm(needed - force) < 0.02 * np.linalg.norm(force)
    return np.linalg.norm(full - coupled) / moved


def test_linear_hand_settles_where_the_full_solver_does(cube):
    solver = make_solver("hybrid", cube)
    node = top_centre(cube)
    start = cube.surface.vertices[node]
    hand = Hand(start, start + [0.004, -0.003, 0.01])
    loop = HapticLoop(solver, position=hand.position, apply_force=hand.apply_force, stiffness=COUPLING,
                      radius=RADIUS)
    assert loop.grab() == node
    assert np.array_equal(loop.tick(), np.zeros(3))  # grabbing alone applies no force
    settle(loop, hand)
    error = check_against_full_solver(loop, hand, make_solver("hybrid", cube), node)
    assert error < 1e-9  # the linear model is affine, so C is exact: round-off only


def test_finite_strain_hand_settles_where_the_full_solver_does(cube):
    solver = make_solver("hybrid", cube, material="neo-hookean")
    node = top_centre(cube)
    start = cube.surface.vertices[node]
    hand = Hand(start, start + [0.003, 0.0, 0.008])
    loop = HapticLoop(solver, position=hand.position, apply_force=hand.apply_force, stiffness=COUPLING,
                      radius=RADIUS)
    loop.grab(node)
    for _ in range(2):  # the visual loop syncs and the tangent is taken again at the force reached
        settle(loop, hand)
        loop.sync()
    settle(loop, hand)
    check_against_full_solver(loop, hand, make_solver("hybrid", cube, material="neo-hookean"), node)


def test_sync_makes_the_force_the_solver_load_and_steps_follow(cube):
    solver = make_solver("hybrid", cube)
    node = top_centre(cube)
    hand = Hand(cube.surface.vertices[node], cube.surface.vertices[node] + [0.0, 0.0, 0.01])
    loop = HapticLoop(solver, position=hand.position, apply_force=hand.apply_force, stiffness=COUPLING,
                      radius=RADIUS)
    loop.grab(node)
    force = settle(loop, hand)
    assert np.array_equal(loop.sync(), force)
    loaded, applied = solver.load
    assert loaded == node and np.array_equal(applied, force) and solver.load_radius == RADIUS
    for _ in range(200):
        solver.step()
    coupled = hand.tool - loop.offset - force / COUPLING
    # stepping rests where the static solve does (implicit steps, 200 × 10 ms); 1e-6 m against a ~5 mm pull
    assert np.linalg.norm(solver.positions[node] - coupled) < 1e-6
    loop.release()
    assert solver.load is None and np.array_equal(loop.tick(), np.zeros(3))


@pytest.mark.parametrize("material", ["linear", "neo-hookean"])
@pytest.mark.parametrize("pending", [False, True], ids=["stepped", "load not stepped yet"])
def test_grab_leaves_the_visual_state_as_it_was(cube, material, pending):
    node = top_centre(cube)
    other = top_centre(cube, (0.01, 0.0, 0.0))
    solvers = [make_solver("hybrid", cube, material=material) for _ in range(2)]
    for solver in solvers:  # the same history: a load being dragged in, half settled
        solver.set_load(other, [0.0, 0.05, 0.1], radius=RADIUS)
        for _ in range(3):
            solver.step()
        if pending:   # a new load the next step brings the warm start and prescribed nodes to
            solver.set_load(other, [0.0, 0.08, 0.2], radius=RADIUS)
    local_response(solvers[0], node, radius=RADIUS)  # four static solves on the live solver
    assert solvers[0].load[0] == other and np.array_equal(solvers[0].load[1], solvers[1].load[1])
    for solver in solvers:
        solver.step()
    # the same arithmetic on the same state: equal to round-off (1e-15 m against the 0.08 m cube)
    assert np.allclose(solvers[0].positions, solvers[1].positions, rtol=0, atol=1e-15)
    assert np.allclose(solvers[0].velocities, solvers[1].velocities, rtol=0, atol=1e-12)


def test_refusals(cube):
    solver = make_solver("hybrid", cube)
    tool = np.array(cube.surface.vertices[top_centre(cube)])
    ok = dict(position=lambda: tool, apply_force=lambda force: None, stiffness=COUPLING, radius=RADIUS)
    for bad in ({"stiffness": 0.0}, {"stiffness": -5.0}, {"stiffness": np.nan}, {"rate": 0.0}, {"rate": -1.0},
                {"position": tool}, {"apply_force": None}, {"radius": 0.0}):
        with pytest.raises(SolverError) as refused:
            HapticLoop(solver, **{**ok, **bad})
        assert str(refused.value)
    with pytest.raises(SolverError, match="needs a solver"):
        HapticLoop(object(), **ok)
    loop = HapticLoop(solver, **ok)
    before = solver.positions.copy()
    fixed = int(solver.fixed[0])
    for node, error in ((solver.node_count, SolverError), (-1, SolverError), (fixed, BoundaryConditionError)):
        with pytest.raises(error):
            loop.grab(node)
        assert loop.response is None and solver.load is None  # a refused grab holds nothing
        assert np.array_equal(solver.positions, before)
    bad = HapticLoop(solver, **{**ok, "position": lambda: [0.0, 0.0]})
    with pytest.raises(SolverError, match="3 coordinates"):
        bad.tick()
    assert issubclass(SolverError, TissuesimError)


def test_thread_ticks_restarts_and_hands_back_its_error(cube):
    solver = make_solver("hybrid", cube)
    node = top_centre(cube)
    tool = np.array(cube.surface.vertices[node])
    received = []
    loop = HapticLoop(solver, position=lambda: tool, apply_force=lambda force: received.append(force.copy()),
                      stiffness=COUPLING, radius=RADIUS)
    loop.grab(node)
    tool += [0.0, 0.0, 0.002]
    ticks = 0
    for _ in range(2):  # a stopped loop starts again
        with loop:
            while loop.ticks < 20:
                time.sleep(0.01)
            assert loop.running
        assert not loop.running
        stats = loop.statistics()
        assert stats.ticks == loop.ticks >= 20 and stats.rate > 0 and 0 < stats.median <= stats.p99 <= stats.longest
        ticks += loop.ticks
    assert len(received) == ticks  # one force handed to the device per tick
    # the tool stood still: every tick handed over the same force, −f of a direct tick (the same arithmetic)
    assert np.array_equal(np.ptp(received, axis=0), np.zeros(3))
    assert np.array_equal(received[-1], -loop.tick())
    assert loop.sync()[2] > 0  # pulled up
    with pytest.raises(SolverError, match="already running"):
        with loop:
            loop.start()
    broken = HapticLoop(solver, position=lambda: [0.0, 0.0], apply_force=lambda force: None, stiffness=COUPLING)
    broken.start()
    broken._thread.join()  # the thread ended on the bad position
    with pytest.raises(SolverError, match="3 coordinates"):
        broken.stop()
    broken.stop()  # the error is handed over once


class RisingDevice:
    """A device for the servo process (picklable: it is opened there): the tool rests at ``start`` for its first
    20 readings, then 2 mm above it."""

    def __init__(self, start):
        self.start = np.array(start, dtype=float)

    def __call__(self):
        readings = [0]

        def position():
            readings[0] += 1
            return self.start + (0.0, 0.0, 0.002 * (readings[0] > 20))

        return position, lambda force: None


class BrokenDevice:
    def __call__(self):
        return (lambda: [0.0, 0.0]), (lambda force: None)


class UnpluggedDevice:
    def __call__(self):
        raise OSError("no such device")


def test_servo_process_exchanges_the_thread_loops_force(cube):
    solver = make_solver("hybrid", cube)
    node = top_centre(cube)
    start = cube.surface.vertices[node]
    loop = HapticProcess(solver, device=RisingDevice(start), stiffness=COUPLING, radius=RADIUS)
    with pytest.raises(SolverError, match="start"):
        loop.grab()  # the tool position lives in the servo process
    for _ in range(2):  # a stopped process starts again
        with loop:
            assert loop.grab() == node  # snapped from the tool position the process reported
            while loop.ticks < 60:
                time.sleep(0.01)
            force = loop.sync()
        stats = loop.statistics()
        assert stats.ticks == loop.ticks >= 60 and 0 < stats.median <= stats.p99 <= stats.longest
        with pytest.raises(SolverError, match="start"):
            loop.grab()  # a stopped device reports no position
    # the same coupling on the same tool in the thread loop: the same arithmetic, so the same force
    twin = HapticLoop(solver, position=lambda: start + (0.0, 0.0, 0.002), apply_force=lambda force: None,
                      stiffness=COUPLING, radius=RADIUS)
    twin._hold(loop.response, loop.offset)
    assert force[2] > 0 and np.array_equal(force, twin.tick())
    assert solver.load[0] == node and np.array_equal(solver.load[1], force)
    broken = HapticProcess(solver, device=BrokenDevice(), stiffness=COUPLING)
    broken.start()
    broken._process.join()  # the process ended on the bad position
    with pytest.raises(SolverError, match="3 coordinates"):
        broken.stop()
    with pytest.raises(SolverError, match="no such device"):
        HapticProcess(solver, device=UnpluggedDevice(), stiffness=COUPLING).start()
    with pytest.raises(SolverError, match="device must be"):
        HapticProcess(solver, device=None, stiffness=COUPLING)


def test_a_new_grab_starts_at_zero_force_and_a_relinearisation_keeps_it(cube):
    solver = make_solver("hybrid", cube)
    node, other = top_centre(cube), top_centre(cube, (0.01, 0.0, 0.0))
    tool = np.array(cube.surface.vertices[node])
    loop = HapticLoop(solver, position=lambda: tool, apply_force=lambda force: None, stiffness=COUPLING,
                      radius=RADIUS)
    loop.grab(node)
    tool += [0.0, 0.0, 0.005]
    loop.tick()
    assert loop.sync()[2] > 0  # node pulled up
    assert loop.grab(other) == other  # the tool where it is: the new coupling's force is zero
    # before the next tick the latest force is the old grab's: the new node gets none of it
    assert np.array_equal(loop.sync(), np.zeros(3))
    assert solver.load[0] == other and np.array_equal(solver.load[1], np.zeros(3))
    tool += [0.0, 0.0, 0.002]
    pulled = loop.tick().copy()
    assert pulled[2] > 0 and np.array_equal(loop.sync(), pulled)
    # finite strain: a sync measures the tangent again, the same grab, so the next sync pushes the same force
    solver = make_solver("hybrid", cube, material="neo-hookean")
    tool[:] = cube.surface.vertices[node]
    loop = HapticLoop(solver, position=lambda: tool, apply_force=lambda force: None, stiffness=COUPLING,
                      radius=RADIUS)
    loop.grab(node)
    tool += [0.0, 0.0, 0.004]
    pulled = loop.tick().copy()
    assert pulled[2] > 0 and np.array_equal(loop.sync(), pulled)
    assert np.array_equal(loop.sync(), pulled)


def test_grab_takes_the_tool_position_the_servo_thread_read(cube):
    solver = make_solver("hybrid", cube)
    node = top_centre(cube)
    tool = np.array(cube.surface.vertices[node])
    readers = []

    def position():
        readers.append(threading.current_thread().name)
        return tool

    loop = HapticLoop(solver, position=position, apply_force=lambda force: None, stiffness=COUPLING,
                      radius=RADIUS)
    with loop:
        assert loop.grab() == node and loop.grab(node) == node
    assert set(readers) == {"tissuesim-haptics"}
    assert np.array_equal(loop.offset, tool - loop.response.origin)
    # no servo ticking (stopped): the grab reads the device once itself, on the caller's thread
    readers.clear()
    loop.grab(node)
    assert readers == [threading.current_thread().name]


def test_a_bad_position_is_quoted_as_it_was_read(cube):
    readings = []

    def flaky():  # returns two coordinates, then fails: the error must quote the first reading
        readings.append(None)
        if len(readings) > 1:
            raise OSError("device read failed")
        return [0.0, 0.0]

    loop = HapticLoop(make_solver("hybrid", cube), position=flaky, apply_force=lambda force: None,
                      stiffness=COUPLING)
    with pytest.raises(SolverError, match=r"3 coordinates \[m\], got \[0.0, 0.0\]"):
        loop.tick()
    assert len(readings) == 1


def test_servo_process_couples_a_node_grabbed_before_it_starts(cube):
    solver = make_solver("hybrid", cube)
    node = top_centre(cube)
    start = cube.surface.vertices[node]
    loop = HapticProcess(solver, device=RisingDevice(start), stiffness=COUPLING, radius=RADIUS)
    assert loop.grab(node) == node  # by index: no tool position needed to choose it
    assert loop.offset is None and np.array_equal(loop.sync(), np.zeros(3))  # nothing pulls yet
    with loop:  # the first tick reads the tool at start: the coupling begins there, at zero force
        assert np.array_equal(loop.offset, start - loop.response.origin)
        while loop.ticks < 60:
            time.sleep(0.01)
        force, held = loop.sync(), loop.response
        loop.grab(node)  # again: the force of the previous grab is not pushed
        assert np.array_equal(loop.sync(), np.zeros(3))
    twin = HapticLoop(solver, position=lambda: start + (0.0, 0.0, 0.002), apply_force=lambda force: None,
                      stiffness=COUPLING, radius=RADIUS)
    twin._hold(held, start - held.origin)
    assert force[2] > 0 and np.array_equal(force, twin.tick())
    # the servo process is the one writer of its report: a release leaves it alone
    report = loop._shared[REPORT].copy()
    loop.release()
    assert np.array_equal(loop._shared[REPORT], report)


def test_grab_on_a_near_field_hybrid_puts_its_window_back():
    """The near field's window of prescribed nodes moves with the contact: the static solves of a grab move it,
    and the next step must not see that."""
    hybrid = HybridMesh.build(models.cube(400))
    node, other = top_centre(hybrid), top_centre(hybrid, (0.02, 0.0, 0.0))
    solvers = [make_solver("hybrid", hybrid, near_field=0.015) for _ in range(2)]
    for solver in solvers:
        solver.set_load(other, [0.0, 0.05, 0.1], radius=RADIUS)
        for _ in range(3):
            solver.step()
    local_response(solvers[0], node, radius=RADIUS)
    assert solvers[0].targets.shape == solvers[1].targets.shape
    for solver in solvers:
        solver.step()
    assert np.allclose(solvers[0].positions, solvers[1].positions, rtol=0, atol=1e-15)
