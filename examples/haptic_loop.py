"""The haptic loop, headless: a simulated hand holds the liver through ``tissuesim.HapticLoop`` (docs/haptics.md).

A device's servo loop turns the tool position into a force 1000 times a second from the grabbed region's local
response and a virtual coupling spring; the visual loop syncs that force into the full solver and steps it. Here a
hand (a mass on a spring pulled toward a target) stands in for the device, first ticked by hand (what a device
driver's own servo callback does), then on the loop's servo thread beside a visual loop.

Run: python examples/haptic_loop.py
"""

import argparse
import time

import numpy as np

import tissuesim
from tissuesim.haptics import HapticLoop

COUPLING = 200.0  # N/m: k_c, the virtual coupling's stiffness
TIP = 0.004       # m: the tool's contact radius
TICK = 1e-3       # s: the servo period (1 kHz)


class Hand:
    """A hand of mass 0.1 kg pulled toward ``target`` ``(3,)`` [m] by a 50 N/m spring, damped, holding the tool;
    it feels the force the loop renders. Semi-implicit Euler steps of ``dt`` [s]."""

    mass, stiffness, damping = 0.1, 50.0, 6.0   # kg, N/m, N s/m

    def __init__(self, start, target):
        self.tool = np.array(start, dtype=float)
        self.velocity = np.zeros(3)
        self.target = np.array(target, dtype=float)
        self.felt = np.zeros(3)                 # the force on the tool [N]

    def position(self):                         # the device's position callback
        return self.tool

    def apply_force(self, force):               # the device's force callback (the array is reused: copy)
        self.felt[:] = force

    def advance(self, dt: float) -> None:
        pull = self.stiffness * (self.target - self.tool) - self.damping * self.velocity + self.felt
        self.velocity += pull / self.mass * dt
        self.tool = self.tool + self.velocity * dt


def liver_solver(resolution: int | None = None):
    surface = tissuesim.models.liver(resolution) if resolution else tissuesim.models.liver()
    return tissuesim.make_solver("hybrid", tissuesim.HybridMesh.build(surface, fine_volume=False))


def hold(solver, *, lift: float = 0.01, ticks: int = 3000) -> dict:
    """The hand grabs the liver's top and pulls toward a point ``lift`` [m] above it; the loop is ticked ``ticks``
    times by hand (a servo callback's way), the hand advancing a tick each time.

    Returns a dict: the grabbed node, the force of the first tick [N], the settled force on the tissue [N], the
    force the hand feels [N], the hand's speed [m/s], and where the coupling puts the node [m].
    """
    x = solver.rest_positions
    top = x[np.argmax(x[:, 2])]
    hand = Hand(top, top + [0.0, 0.0, lift])
    loop = HapticLoop(solver, position=hand.position, apply_force=hand.apply_force, stiffness=COUPLING, radius=TIP)
    node = loop.grab()                          # the node nearest the tool
    first = loop.tick().copy()
    for _ in range(ticks):
        loop.tick()
        hand.advance(TICK)
    force = loop.tick().copy()
    return {"node": node, "first_N": first, "force_N": force, "felt_N": hand.felt.copy(),
            "speed": float(np.linalg.norm(hand.velocity)), "coupled_m": hand.tool - loop.offset - force / COUPLING}


def visual_loop(solver, *, seconds: float = 0.3, frame: float = 1 / 60, lift: float = 0.01) -> dict:
    """The servo loop on its thread while this thread runs a visual loop for ``seconds`` [s]: each ``frame`` [s] it
    syncs the latest force into the solver and steps it once. The hand moves in the servo thread's ticks' time.

    Returns a dict: the frames drawn, the loop's :class:`~tissuesim.haptics.HapticStatistics`, and the grabbed
    node's displacement [m] at the last frame.
    """
    x = solver.rest_positions
    top = x[np.argmax(x[:, 2])]
    hand = Hand(top, top + [0.0, 0.0, lift])

    def apply_force(force):                     # the servo thread's tick: render, and let the hand move
        hand.apply_force(force)
        hand.advance(TICK)

    loop = HapticLoop(solver, position=hand.position, apply_force=apply_force, stiffness=COUPLING, radius=TIP)
    node = loop.grab()
    frames, end = 0, time.perf_counter() + seconds
    with loop:                                  # the servo thread ticks inside the block
        while time.perf_counter() < end:
            loop.sync()                         # its latest force becomes the solver's load
            solver.step()                       # draw solver.positions here
            frames += 1
            time.sleep(frame)
    loop.release()
    return {"frames": frames, "statistics": loop.statistics(), "displacement_m": solver.displacements[node].copy()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0, help="how long the visual loop runs [s]")
    args = parser.parse_args()
    held = hold(liver_solver())
    print(f"held node {held['node']}: the hand settled pulling with {np.round(held['force_N'], 3).tolist()} N")
    run = visual_loop(liver_solver(), seconds=args.seconds)
    stats = run["statistics"]
    print(f"{run['frames']} frames beside the servo thread's {stats.ticks} ticks ({stats.rate:.0f} per second, "
          f"99 % of the intervals under {1e3 * stats.p99:.2f} ms); the node rose "
          f"{1e3 * run['displacement_m'][2]:.2f} mm")


if __name__ == "__main__":
    main()
