"""Accuracy and cost side by side, in one run: the hybrid with its quadratic M_V, the paper's hybrid and the fine FEM
against the converged contact references, and each one's dragged step.

For each model and contact radius R (the contact protocol's cases; a linear method's relative error does not depend
on the force's size or sign, so one pull per R stands for the ten loads): the relative RMSE over the 50 samples
(eq 26 / the reference's RMS displacement) of ``make_solver("hybrid", mesh, element="quadratic")``, of the paper's
hybrid (``element="linear"``) and of ``fem``; then the dragged step of each (the force changed before every step,
as a pin-head drag: CPU ms, fastest of several blocks) and pbd's, and the ratios the issue asks for: quadratic step
/ fem step (target ≤ 1/3) and / pbd step (target ≤ 1). With ``--sizes``, the cost at those sizes of the built-in
liver instead: the time until the first loaded step is done (build included), a new contact's first step, the
dragged step (wall ms, median of 30) and the process's peak memory after each method. Asserts nothing.

    python benchmarks/bench_accuracy.py [--models cube liver] [--steps 30]
    python benchmarks/bench_accuracy.py --sizes 1000 10000
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

import resource

from tissuesim import HybridMesh, make_solver, models
from tissuesim.experiments import contact_protocol, protocol
from tissuesim.experiments.contact_protocol import contact_metrics
from tissuesim.experiments.reference import contact_references
from tissuesim.experiments.sweep_config import ExperimentConfig, load_model

METHODS = {"quadratic": ("hybrid", {"element": "quadratic"}), "paper": ("hybrid", {"element": "linear"}),
           "fem": ("fem", {}), "pbd": ("pbd", {})}
ACCURACY = ("quadratic", "paper", "fem")


def dragged_step_ms(solver, node: int, radius: float, steps: int, repeats: int = 3) -> float:
    """CPU ms of one step with the force changed before it (a drag), the fastest block's mean."""
    solver.reset()
    solver.set_load(node, (0.0, 0.0, 0.5), radius=radius)
    solver.step()
    best = np.inf
    for _ in range(repeats):
        start = time.process_time()
        for k in range(steps):
            solver.move_load(solver.loads[0], force=(0.0, 0.0, 0.5 + 1e-3 * k))
            solver.step()
        best = min(best, (time.process_time() - start) / steps)
    solver.reset()
    return 1e3 * best


def model_rows(spec: str, scale: float, steps: int) -> list[str]:
    hybrid = load_model(spec, ExperimentConfig(models=(spec,), scale=scale))
    rest = np.array(hybrid.surface.vertices)
    node = protocol.load_node(rest, hybrid.surface.triangles)
    radii = [1e-3 * r for r in contact_protocol.RADII_MM]
    references = contact_references(hybrid, node, radii, progress=lambda line: None)
    solvers = {name: make_solver(method, hybrid, **options) for name, (method, options) in METHODS.items()}
    name = contact_protocol._names([spec])[0]
    lines = []
    for radius, reference in zip(radii, references):
        patch = solvers["fem"].contact_patch(node, radius)
        force = np.array([0.0, 0.0, 1.0])
        target = rest + reference.displacements(force)
        errors = {}
        for method in ACCURACY:
            solver = solvers[method]
            solver.reset()
            positions = np.array(solver.solve_static(node, force, radius=radius))
            solver.reset()
            errors[method] = contact_metrics(positions, target, rest, reference.samples, *patch)["relative_rmse"]
        step = {method: dragged_step_ms(solver, node, radius, steps) for method, solver in solvers.items()}
        lines.append(f"{name:22} {1e3 * radius:4.0f}  " + "  ".join(f"{errors[m]:9.3f}" for m in ACCURACY)
                     + f"  {'yes' if errors['quadratic'] <= errors['fem'] else 'no':>9}  "
                     + "  ".join(f"{step[m]:7.2f}" for m in METHODS)
                     + f"  {step['quadratic'] / step['fem']:9.2f}  {step['quadratic'] / step['pbd']:9.2f}")
    return lines


def size_rows(vertices: int) -> list[str]:
    """Build, new contact and dragged step of each method on the built-in liver of ``vertices`` vertices."""
    hybrid = HybridMesh.build(models.liver(vertices), fine_volume=vertices <= 20000)
    rest = hybrid.surface.vertices
    node = protocol.load_node(rest, hybrid.surface.triangles)
    other = int(np.argsort(np.linalg.norm(rest - rest[node], axis=1))[40])
    lines = []
    for name, (method, options) in METHODS.items():
        if method == "fem" and hybrid.fine_volume is None:
            continue
        start = time.perf_counter()
        solver = make_solver(method, hybrid, **options)
        solver.set_load(node, (0.0, 0.0, 0.5), radius=0.004)
        solver.step()
        ready = time.perf_counter() - start
        start = time.perf_counter()
        solver.set_load(other, (0.0, 0.0, 0.5), radius=0.004)
        solver.step()
        contact_s = time.perf_counter() - start
        steps = []
        for k in range(30):
            start = time.perf_counter()
            solver.move_load(solver.loads[0], force=(0.0, 0.0, 0.5 + 1e-3 * k))
            solver.step()
            steps.append(time.perf_counter() - start)
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20
        lines.append(f"{hybrid.surface.vertex_count:9d}  {name:10} {ready:8.2f}  {1e3 * contact_s:11.1f}  "
                     f"{1e3 * np.median(steps):9.2f}  {peak:8.2f}")
        del solver
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="*", help="built-in models or surface files (default: the contact "
                        "protocol's, the shared livers where present)")
    parser.add_argument("--steps", type=int, default=30, help="steps per timed block")
    parser.add_argument("--sizes", nargs="*", type=int, help="time the built-in liver at these vertex counts instead")
    args = parser.parse_args(argv)
    if args.sizes:
        print(f"{'vertices':>9}  {'method':10} {'ready s':>8}  {'contact ms':>11}  {'drag ms':>9}  {'peak GB':>8}")
        for vertices in args.sizes:
            for line in size_rows(vertices):
                print(line, flush=True)
        return 0
    livers = contact_protocol.shared_livers()
    specs = args.models or [*contact_protocol.ContactConfig().models, *livers]
    print("relative RMSE against the converged contact references (one pull per R: linear), and the dragged step "
          "(CPU ms)")
    print(f"{'model':22} {'R mm':>4}  {'quadratic':>9}  {'paper':>9}  {'fem':>9}  {'Q <= fem':>9}  "
          + "  ".join(f"{m:>7}" for m in METHODS) + f"  {'Q / fem':>9}  {'Q / pbd':>9}")
    for spec in specs:
        for line in model_rows(spec, livers.get(spec, 1.0), args.steps):
            print(line, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
