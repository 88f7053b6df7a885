"""Per-step time of our PBD/XPBD surface kernels vs pypbd (PositionBasedDynamics' Python binding), same run.

Both sides get the same mesh, the same constraints in the same order (one distance constraint per edge, one dihedral
constraint per interior edge) and the same number of Gauss–Seidel iterations per step, with no load. A small random
perturbation of the rest shape keeps every constraint active (a surface at rest would make both solvers skip work).

What one pypbd step includes (TimeStepController.step, with no collision detection and no rigid bodies): clearing
accelerations and adding gravity, semi-implicit Euler prediction, MAX_ITERATIONS sweeps over the constraint groups
(graph colouring; OpenMP-parallel inside a group when built with OpenMP — run with OMP_NUM_THREADS=1 for a
single-thread comparison), the velocity update, and a velocity-constraint pass (empty here). Ours: eq 15–18 with the
same sweeps, one Numba call. Prints figures and ratios, and our cost per stretch and per bending projection (steps
with one constraint type only, less an empty step); asserts nothing about time.

    python benchmarks/bench_pbd.py [--iterations 10] [--steps 200] [--resolutions 1402 5000]
"""

from __future__ import annotations

import argparse
import os
import time

# Single-thread comparison: pypbd's constraint groups are OpenMP-parallel when it is built with OpenMP.
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

from tissuesim.mesh import models
from tissuesim.layer.compliance import shell_compliance, shell_masses
from tissuesim.layer.kernels import pbd_step, xpbd_step
from tissuesim.layer.topology import SurfaceConstraints


def _perturbed(surface, seed=0):
    rng = np.random.default_rng(seed)
    mean_edge = float(np.mean(SurfaceConstraints.from_surface(surface).rest_length))
    return surface.vertices + rng.normal(scale=0.05 * mean_edge, size=surface.vertices.shape)


def ours_stepper(surface, c, *, iterations, form, stretch=True, bending=True):
    """One of our steps on the perturbed ``surface``; ``stretch``/``bending`` False leaves that constraint type out."""
    n = surface.vertex_count
    x0 = _perturbed(surface)
    x, v, pred, f = x0.copy(), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    w = 1.0 / shell_masses(surface, thickness=2e-3)
    pre, targets = np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    alpha_s, alpha_b = shell_compliance(c, thickness=2e-3)
    ls, lb = np.zeros(c.stretch_count), np.zeros(c.bending_count)
    dt = 1e-3
    edges, rest_length, hinges, rest_angle = c.edges, c.rest_length, c.bending, c.rest_angle
    if not stretch:
        edges, rest_length = _readonly(np.zeros((0, 2), np.int32)), _readonly(np.zeros(0))
    if not bending:
        hinges, rest_angle = _readonly(np.zeros((0, 4), np.int32)), _readonly(np.zeros(0))

    def step():
        if form == "pbd":
            pbd_step(x, v, pred, w, f, pre, targets, dt, 0.0, iterations, edges, rest_length, 1.0, hinges,
                     rest_angle, 1.0)
        else:
            xpbd_step(x, v, pred, w, f, pre, targets, dt, 0.0, iterations, c.edges, c.rest_length, alpha_s,
                      c.bending, c.rest_angle, alpha_b, ls, lb)

    step()  # compile / load the cache
    x[:] = x0
    v[:] = 0.0
    return step


def _readonly(a):
    a.flags.writeable = False  # as SurfaceConstraints hands them over: the same Numba specialisation
    return a


def per_projection_ns(surface, c, *, iterations, steps):
    """Our PBD form's cost of one stretch and of one bending projection [ns]: steps with only that constraint type,
    less a step with none (prediction and eq 18), per constraint and sweep."""
    kinds = [dict(stretch=False, bending=False), dict(bending=False), dict(stretch=False)]
    none, only_stretch, only_bend = best_of([ours_stepper(surface, c, iterations=iterations, form="pbd", **kind)
                                             for kind in kinds], steps)
    return (1e9 * (only_stretch - none) / (c.stretch_count * iterations),
            1e9 * (only_bend - none) / (c.bending_count * iterations))


def best_of(steppers, steps, repeats=9):
    """Per stepper, the fastest of ``repeats`` blocks of the mean step time in a block [s], in CPU time.

    Blocks of the steppers alternate, so a busy machine slows all of them alike; CPU time rather than wall time, and
    the fastest block, because a descheduled process would otherwise be charged for another's work. Every stepper
    runs single-threaded.
    """
    best = [float("inf")] * len(steppers)
    for _ in range(repeats):
        for k, step in enumerate(steppers):
            start = time.process_time()
            for _ in range(steps):
                step()
            best[k] = min(best[k], (time.process_time() - start) / steps)
    return best


def pypbd_stepper(surface, c, *, iterations):
    import pypbd as pbd

    x0 = _perturbed(surface)
    sim = pbd.Simulation.getCurrent()
    sim.initDefault()
    model = sim.getModel()
    model.cleanup()
    model.addTriangleModel([row for row in x0], surface.triangles.ravel().tolist())
    particles = model.getParticles()
    masses = shell_masses(surface, thickness=2e-3)
    for i, m in enumerate(masses):
        particles.setMass(i, float(m))
    for i, j in c.edges:
        model.addDistanceConstraint(int(i), int(j), 1.0)
    for p1, p2, p3, p4 in c.bending:
        # PositionBasedDynamics' DihedralConstraint takes the opposite vertices first, then the shared edge.
        model.addDihedralConstraint(int(p3), int(p4), int(p1), int(p2), 1.0)
    model.initConstraintGroups()
    ts = sim.getTimeStep()
    ts.setValueUInt(pbd.TimeStepController.MAX_ITERATIONS, iterations)
    ts.setValueUInt(pbd.TimeStepController.NUM_SUB_STEPS, 1)
    pbd.TimeManager.getCurrent().setTimeStepSize(1e-3)
    before = np.array([particles.getPosition(i) for i in range(3)]).reshape(3, 3)
    ts.step(model)
    after = np.array([particles.getPosition(i) for i in range(3)]).reshape(3, 3)
    if np.allclose(before, after):
        raise RuntimeError("pypbd did not move the perturbed surface: constraints not projected")
    count = len(model.getConstraints())
    return (lambda: ts.step(model)), count


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--resolutions", type=int, nargs="+", default=[1402, 2600])
    args = parser.parse_args(argv)
    print(f"threads: OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}, "
          f"NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS', 'unset')}; iterations {args.iterations}")
    header = (f"{'vertices':>8} {'constraints':>11} {'ours PBD ms':>11} {'ours XPBD ms':>12} {'pypbd ms':>9} "
              f"{'PBD/pypbd':>9} {'XPBD/pypbd':>10} {'ns/c/it ours':>12} {'ns/c/it pypbd':>13}")
    print(header)
    for resolution in args.resolutions:
        surface = models.sphere(resolution)
        c = SurfaceConstraints.from_surface(surface)
        constraints = c.stretch_count + c.bending_count
        steppers = [ours_stepper(surface, c, iterations=args.iterations, form="pbd"),
                    ours_stepper(surface, c, iterations=args.iterations, form="xpbd")]
        try:
            theirs_step, count = pypbd_stepper(surface, c, iterations=args.iterations)
            assert count == constraints, (count, constraints)
            steppers.append(theirs_step)
        except ImportError:
            print("pypbd is not installed (pip install pypbd); timing ours only")
        times = best_of(steppers, args.steps)
        ours, ours_x = times[:2]
        theirs = times[2] if len(times) > 2 else float("nan")
        per = 1e9 / (constraints * args.iterations)
        print(f"{surface.vertex_count:>8} {constraints:>11} {ours * 1e3:>11.3f} {ours_x * 1e3:>12.3f} "
              f"{theirs * 1e3:>9.3f} {ours / theirs:>9.3f} {ours_x / theirs:>10.3f} {ours * per:>12.1f} "
              f"{theirs * per:>13.1f}")
        stretch_ns, bend_ns = per_projection_ns(surface, c, iterations=args.iterations, steps=args.steps)
        print(f"{'':>8} ours (PBD) per projection: stretch {stretch_ns:.1f} ns, bending {bend_ns:.1f} ns")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
