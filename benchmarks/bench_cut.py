"""Cost of cutting (§7): one scalpel move against the triangles it crosses and the mesh size, the step after many
cuts, and the fine FEM's cost for the same cut (re-tetrahedralize + re-factorize K) side by side.

    PYTHONPATH=src python benchmarks/bench_cut.py [--sizes 1000 10000 100000] [--quick]

Prints figures and ratios; asserts nothing (timings belong here, not in tests). Move costs are CPU time of this
process (the code is single-threaded, so it equals wall time on an idle machine and is not inflated by other jobs).

1. **one move**: a progressive 3 cm cut over the cube's flat top in moves of 0.5–3 edge lengths (so each crosses
   about k triangles), on cubes of 1k, 10k and 100k vertices: the pure function
   :func:`tissuesim.cutting.cut_surface` (new arrays: O(n) copies by design), the in-place core
   (:class:`tissuesim.cutting.buffers.CutSurface`: plan + apply on capacity buffers, what the scalpel runs), and the
   whole scalpel move on a pbd and on a hybrid solver (core + the solver's arrays). Medians over the moves but
   the first (which builds the buffers and fans).
2. **step after 50 cuts**: hybrid step time on the Table-1 cube before and after ~50 cutting moves in five
   strokes, with the implicit and the XPBD integrator (the kernels also sweep the retired rows); the cut adds
   vertices, so the ratio per vertex is printed too.
3. **fine FEM for the same cut**: TetGen on the cut M_S (fine switches) + assembly and factorization of K, the
   work a volumetric FEM would redo for each move, against one hybrid move.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import tissuesim
from tissuesim.cutting import DEFAULT_SNAP, Sweep, cut_surface
from tissuesim.cutting.buffers import CutSurface
from tissuesim.experiments.wound import incision_line, scripted_incision
from tissuesim.mesh import models


def _edge(surface) -> float:
    e = surface.edges
    return float(np.linalg.norm(surface.vertices[e[:, 0]] - surface.vertices[e[:, 1]], axis=1).mean())


def _line(surface):
    """A 3 cm line over the middle of the cube's flat top, just above it (tool height 1 mm), and the blade."""
    top = surface.vertices[:, 2].max()
    start = np.array([-0.015, 1.1e-3, top + 1e-3])
    return start, start + [0.03, 0.0, 0.0]


def _moves(step):
    return np.arange(step, 0.03 + 1e-12, step) / 0.03


def bench_pure(surface, step):
    """Progressive moves of ``step`` [m] along the line with :func:`cut_surface`: (median k, median seconds)."""
    rest, tri = surface.vertices, surface.triangles
    positions, velocities = rest.copy(), np.zeros_like(rest)
    start, end = _line(surface)
    closed = np.zeros((0, 2), dtype=np.int64)
    tip, times, split = start, [], []
    for f in _moves(step):
        new = start + f * (end - start)
        t = time.process_time()
        r = cut_surface(rest, positions, velocities, tri, Sweep.between(tip, new, [0.0, 0.0, -0.01]), closed=closed)
        times.append(time.process_time() - t)
        tip = new
        if r is not None:
            if r.end_vertex >= 0:
                tip = r.positions[r.end_vertex] + [0.0, 0.0, 1e-3]
            rest, positions, velocities, tri, closed = r.rest, r.positions, r.velocities, r.triangles, r.closed
            split.append(r.split_count)
    return statistics.median(split), statistics.median(times[1:] or times)


def bench_in_place(surface, step):
    """The same with the in-place core, its next sweep searched from where the last cut stopped."""
    rest = surface.vertices
    cut = CutSurface(rest, rest, np.zeros_like(rest), surface.triangles)
    start, end = _line(surface)
    closed, seeds = np.zeros((0, 2), dtype=np.int64), []
    tip, times, split = start, [], []
    for f in _moves(step):
        new = start + f * (end - start)
        t = time.process_time()
        sweep = Sweep.between(tip, new, [0.0, 0.0, -0.01])
        plan = cut.plan(sweep, snap=DEFAULT_SNAP, closed=closed, seeds=seeds)
        r = None if plan is None else cut.apply(plan, sweep)
        times.append(time.process_time() - t)
        tip = new
        if r is not None:
            if r.end_vertex >= 0:
                tip, seeds = r.positions[r.end_vertex] + [0.0, 0.0, 1e-3], [r.end_vertex]
            closed = r.closed
            split.append(r.split_count)
    return statistics.median(split), statistics.median(times[1:] or times)


def bench_solver_moves(hybrid, step, method):
    """The same with the scalpel on a ``method`` solver (core + the solver's arrays): (median k, median seconds)."""
    solver = tissuesim.make_solver(method, hybrid)
    start, end = _line(hybrid.surface)
    scalpel = tissuesim.Scalpel(solver, depth=0.01)
    scalpel.press(start, direction=[0, 0, -1])
    times, split = [], []
    for f in _moves(step):
        t = time.process_time()
        report = scalpel.move(start + f * (end - start))
        times.append(time.process_time() - t)
        if report.triangles_split:
            split.append(report.triangles_split)
    return statistics.median(split), statistics.median(times[1:] or times)   # the first move builds the buffers


def bench_steps(hybrid, steps, integrator, *, rounds=7):
    """Hybrid step time on an uncut and on a cut solver (~50 cutting moves in five strokes), timed in alternating
    rounds so that the machine's drift cancels: (median ratio cut / uncut, its lowest and highest, uncut step [s],
    cutting moves, retired stretch rows, stretch rows, vertices before, vertices after)."""
    uncut, cut = (tissuesim.make_solver("hybrid", hybrid, integrator=integrator) for _ in range(2))
    start, end = incision_line(cut.rest_positions, length=0.02)
    moves = 0
    for offset in (-0.012, -0.006, 0.0, 0.006, 0.012):
        shift = np.array([0.0, offset, 0.0])
        scalpel = tissuesim.Scalpel(cut, depth=0.01)
        scalpel.press(start + shift, direction=[0, 0, -1])
        for f in np.linspace(0, 1, 14)[1:]:
            moves += scalpel.move(start + shift + f * (end - start)).triangles_split > 0
        scalpel.release()
    for solver in (uncut, cut):
        solver.set_load(int(np.argmax(solver.rest_positions[:, 2])), [0.0, 0.0, 0.5])
        solver.step()

    def timed(solver):
        t = time.process_time()
        for _ in range(steps):
            solver.step()
        return (time.process_time() - t) / steps

    pairs = [(timed(uncut), timed(cut)) for _ in range(rounds)]
    ratios = sorted(after / before for before, after in pairs)
    c = cut.constraints
    retired = int(np.count_nonzero(c.edges[:, 0] == c.edges[:, 1]))
    return (statistics.median(ratios), ratios[0], ratios[-1], statistics.median(b for b, _ in pairs), moves, retired,
            len(c.edges), len(uncut.positions), len(cut.positions))


def bench_fine_fem(solver_after_cut):
    from tissuesim.fem.linear import LinearFEM
    from tissuesim.mesh.tetrahedralize import FINE_SWITCHES, tetrahedralize

    surface = solver_after_cut.hybrid.surface
    t = time.perf_counter()
    try:
        volume, _ = tetrahedralize(surface, switches=FINE_SWITCHES)
    except tissuesim.MeshError as error:
        return None, f"TetGen refuses the cut surface ({error}); timing the uncut one instead"
    mesh_s = time.perf_counter() - t
    t = time.perf_counter()
    LinearFEM(volume, youngs_modulus=5500.0, poisson_ratio=0.3,
              fixed=np.flatnonzero(volume.points[:, 2] <= volume.points[:, 2].min() + 0.008))
    return (mesh_s, time.perf_counter() - t, volume.element_count), None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000, 100000])
    parser.add_argument("--solver-limit", type=int, default=100000,
                        help="largest M_S for the solver-level moves (its hybrid mesh build takes minutes beyond)")
    parser.add_argument("--quick", action="store_true", help="fewer timed steps")
    args = parser.parse_args()
    print("## 1. one move: median time against triangles crossed (k) and M_S size\n")
    print("| M_S vertices | move (edge lengths) | k (core) | cut_surface, new arrays [ms] | in-place core [ms] "
          "| k (scalpel) | scalpel move, pbd [ms] | scalpel move, hybrid [ms] |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for size in args.sizes:
        surface = models.cube(size)
        edge = _edge(surface)
        hybrid = None
        if size <= args.solver_limit:
            hybrid = tissuesim.HybridMesh.build(surface, fine_volume=False)
        for f in (0.5, 1.0, 2.0, 3.0):
            _, t_pure = bench_pure(surface, f * edge)
            k, t_core = bench_in_place(surface, f * edge)
            k_move, moves = "-", ["-", "-"]
            if hybrid is not None:
                for i, method in enumerate(("pbd", "hybrid")):
                    k_move, seconds = bench_solver_moves(hybrid, f * edge, method)
                    moves[i] = f"{1e3 * seconds:.2f}"
            print(f"| {size} | {f:g} | {k:g} | {1e3 * t_pure:.2f} | {1e3 * t_core:.2f} | {k_move} | {moves[0]} "
                  f"| {moves[1]} |", flush=True)

    print("\n## 2. hybrid step after 50 cuts (Table-1 cube): a cut and an uncut solver timed in alternating rounds\n")
    print("| integrator | uncut step [ms] | cutting moves | step ratio cut / uncut, median (range) "
          "| vertices uncut → cut | ratio per vertex | retired stretch rows |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    cube = tissuesim.HybridMesh.build(models.cube())
    for integrator, steps in (("implicit", 1000), ("xpbd", 100)):
        ratio, low, high, before, moves, retired, rows, n0, n1 = bench_steps(
            cube, steps // 5 if args.quick else steps, integrator)
        print(f"| {integrator} | {1e3 * before:.3f} | {moves} | {ratio:.3f} ({low:.3f}–{high:.3f}) | {n0} → {n1} "
              f"| {ratio * n0 / n1:.3f} | {retired} of {rows} |", flush=True)

    print("\n## 3. the fine FEM's cost for the same cut, against one hybrid move\n")
    solver = tissuesim.make_solver("hybrid", cube)
    run = scripted_incision(solver)
    move = statistics.median(r.seconds for r in run["moves"][1:-1])
    figures, note = bench_fine_fem(solver)
    if figures is None:
        print(note)
        figures, _ = bench_fine_fem(tissuesim.make_solver("hybrid", cube))
    mesh_s, factor_s, tets = figures
    print(f"one hybrid scalpel move (median): {1e3 * move:.2f} ms")
    print(f"fine FEM: TetGen {1e3 * mesh_s:.1f} ms + assemble/factorize K {1e3 * factor_s:.1f} ms ({tets} tets) = "
          f"{1e3 * (mesh_s + factor_s):.1f} ms, {(mesh_s + factor_s) / move:.0f}x one move")


if __name__ == "__main__":
    main()
