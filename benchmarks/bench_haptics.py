"""The haptic loop's rate and jitter while the visual loop steps the full solver, on spheres from
``models.sphere(n)``.

    OMP_NUM_THREADS=1 python benchmarks/bench_haptics.py [--sizes 1000 10000 100000] [--seconds 3] [--tool grasper]

Per size: the hybrid (linear material, mesh built without its fine volume), a 4 mm tip on the top node, a simulated
device whose tool circles 5 mm above its grab point at 0.5 Hz (the servo loop calls its position; its force is
kept). ``--tool grasper``: the device holds jaws of the same radius instead of the tip (the visual loop's sync
settles them where the coupling puts them). Printed: the grab's cost (the local response: four static solves, or a
grasper's four static moves; the first grab, then a new node), then
for each case over ``--seconds``: the ticks per second, the interval between tick starts (median, p99, longest)
[ms], the ticks that started more than a period late, and the visual loop's step (sync + step) median [ms].

1. **idle**: the main thread sleeps; the servo thread alone.
2. **visual 60 Hz**: every 1/60 s the main thread syncs and steps the solver, then sleeps to the next frame.
3. **visual 60 Hz, switch interval 0.1 ms**: the same with ``sys.setswitchinterval(1e-4)``.
4. **process, visual 60 Hz**: case 2 with the servo loop in a process of its own (:class:`HapticProcess`; its
   statistics include its start, the grab and its first ticks).

CPython's GIL lets one thread run Python at a time. A solver call on the main thread that holds the GIL (NumPy
and Numba code, CHOLMOD through cvxopt) delays the servo thread until it returns or the interpreter switches
threads (every 5 ms by default: case 3 lowers that), so the longest interval grows with the step's cost. Kernels
that release the GIL (Numba ``nogil=True``, a sparse solver that releases it; cvxopt's CHOLMOD does not) would
remove the delay for the thread; case 4 avoids it: the servo loop in a process of its own, reading the coupling
from shared memory. Asserts nothing.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

from tissuesim import HybridMesh, make_solver
from tissuesim.haptics import HapticLoop, HapticProcess
from tissuesim.mesh import models

RADIUS = 0.004  # m
COUPLING = 200.0  # N/m
FRAME = 1.0 / 60.0  # s: the visual loop's rate


class CirclingTool:
    """A device whose tool circles 5 mm above ``centre`` at 0.5 Hz in a vertical plane; calling it opens it and
    returns its ``(position, apply_force)`` (picklable, so the servo process can open it too)."""

    def __init__(self, centre):
        self.centre = np.array(centre, dtype=float)

    def __call__(self):
        start, force = time.perf_counter(), np.zeros(3)

        def position():
            phase = np.pi * (time.perf_counter() - start)
            return self.centre + 0.005 * np.array([np.sin(phase), 0.0, 1.0 - np.cos(phase)])

        def apply_force(value):
            force[:] = value

        return position, apply_force


def run_case(loop, solver, seconds: float, *, visual: bool, node: int | None = None) -> tuple:
    """Run the servo loop for ``seconds`` (grabbing ``node`` once it runs, if given); with ``visual``, sync and
    step at 60 Hz meanwhile. Returns the statistics and the visual loop's step times [s]."""
    steps = []
    with loop:
        if node is not None:
            loop.grab(node)
        end = time.perf_counter() + seconds
        frame = time.perf_counter()
        while time.perf_counter() < end:
            if visual:
                start = time.perf_counter()
                loop.sync()
                solver.step()
                steps.append(time.perf_counter() - start)
            frame += FRAME
            time.sleep(max(0.0, frame - time.perf_counter()))
    return loop.statistics(), steps


def bench(size: int, seconds: float, tool: str) -> None:
    start = time.perf_counter()
    hybrid = HybridMesh.build(models.sphere(size), fine_volume=False)
    solver = make_solver("hybrid", hybrid)
    print(f"\n## sphere({size}): {hybrid.surface.vertices.shape[0]} M_S vertices, built in "
          f"{time.perf_counter() - start:.1f} s")
    x = hybrid.surface.vertices
    top = int(np.argmax(x[:, 2]))
    device = CirclingTool(x[top])
    position, apply_force = device()
    loop = HapticLoop(solver, position=position, apply_force=apply_force, stiffness=COUPLING, radius=RADIUS,
                      tool=tool)
    # a node 30° down the sphere for the first grab: a patch never loaded before
    direction = np.array([np.sin(np.pi / 6), 0.0, np.cos(np.pi / 6)])
    other = int(np.argmax((x - x.mean(axis=0)) @ direction))
    for label, node in (("first grab", other), ("grab of a new node", top)):
        start = time.perf_counter()
        loop.grab(node)
        print(f"{label}: {1e3 * (time.perf_counter() - start):.1f} ms (its local response: the pin-head's 4 static "
              "solves; the grasper's from the solver's compliance, or 4 static moves without it)")
    compliance = loop.response.compliance
    held = "" if loop.grasper is None else f" ({loop.grasper.held.size} vertices in the jaws)"
    print(f"C at the top node{held} [mm/N]: diagonal {np.round(1e3 * np.diag(compliance), 2).tolist()}")
    print("| case | ticks/s | interval median / p99 / longest [ms] | late ticks | step median [ms] |")
    print("|---|---:|---:|---:|---:|")
    interval = sys.getswitchinterval()
    process = HapticProcess(solver, device=device, stiffness=COUPLING, radius=RADIUS, tool=tool)
    for label, servo, visual, switch in (
            ("thread, idle", loop, False, interval), ("thread, visual 60 Hz", loop, True, interval),
            ("thread, visual 60 Hz, switch 0.1 ms", loop, True, 1e-4),
            ("process, visual 60 Hz", process, True, interval)):
        if servo is process:
            loop.release()  # the process holds the node next (two graspers cannot hold one patch)
        sys.setswitchinterval(switch)
        try:
            stats, steps = run_case(servo, solver, seconds, visual=visual, node=top if servo is process else None)
        finally:
            sys.setswitchinterval(interval)
        step = f"{1e3 * np.median(steps):.2f}" if steps else "–"
        print(f"| {label} | {stats.rate:.0f} | {1e3 * stats.median:.3f} / {1e3 * stats.p99:.3f} / "
              f"{1e3 * stats.longest:.2f} | {stats.late} of {stats.ticks} | {step} |")
    process.release()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000], help="sphere vertex counts")
    parser.add_argument("--seconds", type=float, default=3.0, help="length of each case [s]")
    parser.add_argument("--tool", choices=["pin-head", "grasper"], default="pin-head", help="what the device holds")
    args = parser.parse_args(argv)
    print(f"haptic loop: target 1000 ticks/s; OMP_NUM_THREADS={os.environ['OMP_NUM_THREADS']}, "
          f"{os.cpu_count()} CPUs, default switch interval {1e3 * sys.getswitchinterval():g} ms")
    for size in args.sizes:
        bench(size, args.seconds, args.tool)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
