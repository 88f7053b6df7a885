"""Finite strain against linear in the same run: the hybrid's step, and the static solve of a 5 N pull.

Prints, per sphere size (``models.sphere(n)``), the hybrid step with material="linear" and "neo-hookean" and their
ratio (the target is ≤ 2), for a settled constant load and for a drag (the load changed before every step, as a
pin-head does); then, on the default models, the time of a static 5 N pull over a 4 mm patch per method and
material (target ≤ 1 s). CPU time, medians and ranges over blocks. Asserts nothing about time.

    python benchmarks/bench_finite_strain.py [--sizes 1000 10000] [--steps 20] [--material neo-hookean]
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

from tissuesim import HybridMesh, make_solver
from tissuesim.experiments.protocol import load_node
from tissuesim.mesh import models

RADIUS = 0.004


def blocks_of(step, steps: int, repeats: int = 5) -> np.ndarray:
    """CPU seconds per call of ``step``, one entry per block of ``steps`` calls."""
    times = []
    for _ in range(repeats):
        start = time.process_time()
        for _ in range(steps):
            step()
        times.append((time.process_time() - start) / steps)
    return np.array(times)


def describe(times: np.ndarray) -> str:
    return f"{1e3 * np.median(times):8.2f} ms [{1e3 * times.min():.2f}, {1e3 * times.max():.2f}]"


def step_costs(hybrid, material: str, steps: int) -> dict:
    node = load_node(hybrid.surface.vertices, hybrid.surface.triangles)
    solver = make_solver("hybrid", hybrid, material=material)
    solver.set_load(node, (0.0, 0.0, 0.5), radius=RADIUS)
    for _ in range(60):      # settle: the finite-strain volume stops iterating once at equilibrium
        solver.step()
    constant = blocks_of(solver.step, steps)
    phase = [0.0]

    def drag():
        phase[0] += 0.05
        solver.set_load(node, (0.2 * np.sin(phase[0]), 0.0, 0.5), radius=RADIUS)
        solver.step()

    return {"constant": constant, "drag": blocks_of(drag, steps)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--material", default="neo-hookean")
    args = parser.parse_args(argv)
    print(f"hybrid step, {args.material} vs linear (CPU ms per step, median [range] of 5 blocks of {args.steps})")
    for size in args.sizes:
        hybrid = HybridMesh.build(models.sphere(size), fine_volume=False)
        linear = step_costs(hybrid, "linear", args.steps)
        finite = step_costs(hybrid, args.material, args.steps)
        for kind in ("constant", "drag"):
            ratio = np.median(finite[kind]) / np.median(linear[kind])
            print(f"  sphere {hybrid.surface.vertex_count:>6} {kind:8}: linear {describe(linear[kind])}  "
                  f"{args.material} {describe(finite[kind])}  ratio {ratio:.2f}")
    print("static 5 N pull over a 4 mm patch (wall s, one solve from rest)")
    for name in models.MODELS:
        hybrid = HybridMesh.build(models.model(name))
        node = load_node(hybrid.surface.vertices, hybrid.surface.triangles)
        for method in ("hybrid", "embedded", "fem"):
            row = []
            for material in ("linear", args.material):
                solver = make_solver(method, hybrid, material=material)
                solver.solve_static(node, (0.0, 0.0, 0.01), radius=RADIUS)   # compile and factorise first
                start = time.perf_counter()
                solver.solve_static(node, (0.0, 0.0, 5.0), radius=RADIUS)
                row.append(f"{material} {time.perf_counter() - start:7.3f} s")
            print(f"  {name:6} {method:9}: " + "   ".join(row))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
