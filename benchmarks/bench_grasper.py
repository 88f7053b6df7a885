"""The grasper in the user's loop: the first frame after the click and a dragged frame, beside the pin-head's frame
in the same run, on spheres from ``models.sphere(n)``.

    OMP_NUM_THREADS=1 python benchmarks/bench_grasper.py [--sizes 1000 10000] [--methods hybrid fem ...]

For each method (and the hybrid's neo-Hookean and quadratic M_V variants): jaws of 4 mm at the top grab and lift the
patch 5 mm (the first frame: grab plus :meth:`~tissuesim.Grasper.follow` and a step, as the viewer does after a
click), then are dragged 0.5 mm sideways a frame for 20 frames (``follow`` and the step after it: a static settle,
or on the finite-strain hybrid one relaxed update, whose patch then lags its jaws). Beside it, the pin-head's frame
(drag plus step) on a twin solver. Prints the frames' medians [ms], the iterations each needed, how far the held
vertices are from the jaws' targets after each frame [µm] and the grasper's frame over the pin-head's. Asserts
nothing.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

from tissuesim import Grasper, HybridMesh, PinHead, make_solver
from tissuesim.mesh import models

JAWS = 0.004           # [m]
LIFT = 0.005           # [m]
DRAG = 0.0005          # [m] a frame
FRAMES = 20
VARIANTS = {"hybrid": ("hybrid", {}), "hybrid neo-hookean": ("hybrid", {"material": "neo-hookean"}),
            "hybrid quadratic": ("hybrid", {"element": "quadratic"}), "embedded": ("embedded", {}),
            "pbd": ("pbd", {}), "fem": ("fem", {})}


def grasper_frames(solver, top: np.ndarray) -> tuple[float, list[float], list[int], float]:
    """``(first frame [s], dragged frames [s], their iterations, largest miss after a frame [m])``."""
    grasper = Grasper(solver, radius=JAWS)
    start = time.perf_counter()
    grasper.grab(top)
    grasper.follow(top + [0.0, 0.0, LIFT])
    solver.step()
    first = time.perf_counter() - start
    frames, iterations, miss = [], [], 0.0
    for frame in range(1, FRAMES + 1):
        jaws = top + [DRAG * frame, 0.0, LIFT]
        start = time.perf_counter()
        grasper.follow(jaws)
        solver.step()
        frames.append(time.perf_counter() - start)
        iterations.append(grasper.iterations)
        miss = max(miss, float(np.linalg.norm(grasper.targets() - solver.positions[grasper.held], axis=1).max()))
    return first, frames, iterations, miss


def pin_head_frames(solver, top: np.ndarray) -> list[float]:
    pin = PinHead(solver, stiffness=50.0, radius=JAWS)
    pin.grab(top)
    frames = []
    for frame in range(1, FRAMES + 1):
        start = time.perf_counter()
        pin.drag(top + [DRAG * frame, 0.0, LIFT])
        solver.step()
        frames.append(time.perf_counter() - start)
    return frames


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--methods", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    args = parser.parse_args()
    print(f"{'size':>7} {'method':<20} {'first ms':>9} {'frame ms':>9} {'iters':>6} {'miss µm':>8} "
          f"{'pin ms':>8} {'ratio':>6}")
    for size in args.sizes:
        hybrid = HybridMesh.build(models.sphere(size), fine_volume="fem" in args.methods)
        top = hybrid.surface.vertices[np.argmax(hybrid.surface.vertices[:, 2])].copy()
        for label in args.methods:
            method, options = VARIANTS[label]
            first, frames, iterations, miss = grasper_frames(make_solver(method, hybrid, **options), top)
            pin = pin_head_frames(make_solver(method, hybrid, **options), top)
            frame, pinned = float(np.median(frames)), float(np.median(pin))
            print(f"{size:>7} {label:<20} {1e3 * first:>9.1f} {1e3 * frame:>9.2f} {np.median(iterations):>6.0f} "
                  f"{1e6 * miss:>8.2f} {1e3 * pinned:>8.2f} {frame / pinned:>6.1f}", flush=True)


if __name__ == "__main__":
    main()
