"""The user's interactive loop at scale: steps under a held and a dragged pin-head, cutting moves and the step after
each, and the first grab of a new node, on spheres from ``models.sphere(n)``; figures and the ratios of issue 20.

    OMP_NUM_THREADS=1 python benchmarks/bench_interactive.py [--sizes 1000 10000 100000] [--quick]

OMP_NUM_THREADS=1 is the default here (set it to 2 to see what two cores give). Wall time per call
(``time.perf_counter``) on the hybrid mesh built without its fine volume (so the fem method is skipped): the default
hybrid beside ``material="neo-hookean"``; medians and [min, max]. The 100k sphere takes minutes to build, so it runs
only when asked. Asserts nothing.

1. **constant load**: steps with 0.5 N held on a 4 mm patch at the top, after 60 steps to settle; the materials'
   blocks are interleaved so the machine's drift hits both alike.
2. **drag**: the same patch, the force turned by 0.05 rad about the vertical before every step (set_load + step
   timed together).
3. **cutting**, for every method that can be cut: 0.1 N held on a 4 mm patch 2 cm beside the line, a progressive cut
   over the top (blade 1 cm straight down from 5 mm above the surface, moves of 1.5 edge lengths, 4 cm at most; the
   first move, which builds the cut buffers, untimed) with three steps after each move. Over the moves that split
   triangles: the move, the step after it, their sum against the 60 Hz frame, the later steps, and the step after
   a move over the same solver's uncut step (target ≤ 2).
4. **first grab**: settled under the load at the top, the load moved to nodes never grabbed before, 35° down the
   sphere and far apart (a 4 mm patch on five, a point load on five others; three each with --quick): set_load + the
   first step, over the constant-load step (target ≤ 3 steps) and over the drag step (a resting neo-Hookean volume
   skips its iterations, so its constant-load step is the cheaper one).
5. **summary**: one row per size with the targets (the drag step ≤ 2 ms at 10k and ≤ 16 ms at 100k, neo-Hookean
   over linear drag ≤ 2), and the drag step's growth exponent from the smallest size to the largest (≤ 1.1).
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

from tissuesim import HybridMesh, Scalpel, make_solver
from tissuesim.experiments.wound import INCISION_DEPTH, PULL_FORCE, incision_line
from tissuesim.mesh import models

RADIUS = 0.004          # the pin-head's contact patch [m]
FORCE = 0.5             # [N]
FRAME = 1.0 / 60.0      # one viewer frame [s]
CUT_POLAR = 0.41        # the load held while cutting: 2 cm off the cut on the 5 cm sphere [rad down from the top]
GRAB_POLAR = np.radians(35.0)
DRAG_TARGET = {10000: 2e-3, 100000: 16e-3}
#: label: (method, options); the first two are stepped and grabbed, all of them cut
METHODS = {"hybrid": ("hybrid", {}), "hybrid neo-hookean": ("hybrid", {"material": "neo-hookean"}),
           "pbd": ("pbd", {}), "embedded": ("embedded", {})}
MATERIALS = ("hybrid", "hybrid neo-hookean")


def timed(call) -> float:
    start = time.perf_counter()
    call()
    return time.perf_counter() - start


def describe(times) -> str:
    """Median [min, max] in ms of ``times`` [s]."""
    times = 1e3 * np.asarray(times)
    return f"{np.median(times):7.2f} ms [{times.min():.2f}, {times.max():.2f}]"


def pulled(angle: float, force: float = FORCE) -> np.ndarray:
    """The pin-head's pull ``(3,)`` [N]: ``force`` tilted 30° from straight up, turned ``angle`` rad about z."""
    return force * np.array([0.5 * np.cos(angle), 0.5 * np.sin(angle), np.sqrt(0.75)])


def surface_node(rest: np.ndarray, polar: float, azimuth: float) -> int:
    """The M_S vertex nearest the sphere's point ``polar`` rad down from its top at ``azimuth`` rad."""
    centre = 0.5 * (rest.min(axis=0) + rest.max(axis=0))
    radius = 0.5 * np.ptp(rest[:, 2])
    direction = [np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)]
    return int(np.argmin(np.linalg.norm(rest - (centre + radius * np.array(direction)), axis=1)))


def loaded(hybrid, label: str, *, settle: int, polar: float = 0.0, azimuth: float = 0.0, force: float = FORCE):
    """(solver, node): ``label``'s solver pulled by ``force`` [N] on a 4 mm patch there, after ``settle`` steps (the
    finite-strain volume stops iterating once it rests, so its steps are timed at rest)."""
    method, options = METHODS[label]
    solver = make_solver(method, hybrid, **options)
    node = surface_node(solver.rest_positions, polar, azimuth)
    solver.set_load(node, pulled(0.0, force), radius=RADIUS)
    for _ in range(settle):
        solver.step()
    return solver, node


def steps(held: dict, *, drag: bool, rounds: int, per_round: int) -> dict:
    """Seconds per step of each ``label: (solver, node)``, in interleaved blocks; ``drag`` turns the force first."""
    times = {label: [] for label in held}
    for r in range(rounds):
        for label, (solver, node) in held.items():
            for k in range(per_round):
                if drag:
                    force = pulled(0.05 * (r * per_round + k + 1))
                    times[label].append(timed(lambda: (solver.set_load(node, force, radius=RADIUS), solver.step())))
                else:
                    times[label].append(timed(solver.step))
    return times


def cutting(hybrid, label: str, *, moves: int, settle: int, uncut: int) -> dict:
    """Seconds of ``uncut`` steps, and per move that cut: the move, the step after it, the two later steps."""
    solver, _ = loaded(hybrid, label, settle=settle, polar=CUT_POLAR, azimuth=np.pi / 2, force=PULL_FORCE)
    times = {"uncut": [timed(solver.step) for _ in range(uncut)], "move": [], "after": [], "later": [], "split": []}
    length = min((moves + 1) * 1.5 * hybrid.surface.mean_edge_length, 0.04)
    # over the top as the held load left it, the tip 5 mm above it: the surface still rises under pbd's load
    start, end = (point + [0.0, 0.0, 0.004] for point in incision_line(solver.positions, length=length))
    scalpel = Scalpel(solver, depth=INCISION_DEPTH)
    scalpel.press(start, direction=[0.0, 0.0, -1.0])
    for i, f in enumerate(np.linspace(0.0, 1.0, moves + 2)[1:]):
        clock = time.perf_counter()
        report = scalpel.move(start + f * (end - start))
        move = time.perf_counter() - clock
        after = timed(solver.step)
        later = [timed(solver.step) for _ in range(2)]
        if i and report.triangles_split:       # the first move builds the cut buffers
            times["move"].append(move)
            times["after"].append(after)
            times["later"].extend(later)
            times["split"].append(report.triangles_split)
    times["edges per move"] = length / (moves + 1) / hybrid.surface.mean_edge_length
    times["moves"] = moves
    return times


def grabs(hybrid, label: str, *, count: int, settle: int, between: int) -> dict:
    """Seconds of set_load and of the first step on ``count`` new nodes per radius (4 mm, then a point load), after
    ``settle`` steps under the first load and ``between`` steps under each new one."""
    solver, _ = loaded(hybrid, label, settle=settle)
    times = {}
    for shift, radius in ((0.0, RADIUS), (np.pi / count, None)):
        record = times.setdefault(radius, {"set_load": [], "first": []})
        for azimuth in shift + 2 * np.pi * np.arange(count) / count:
            node = surface_node(solver.rest_positions, GRAB_POLAR, azimuth)
            record["set_load"].append(timed(lambda: solver.set_load(node, pulled(0.0), radius=radius)))
            record["first"].append(timed(solver.step))
            for _ in range(between):
                solver.step()
    return times


def report_steps(hybrid, args) -> dict:
    """Print sections 1-2; ``{label: (constant, drag)}`` median seconds per step."""
    held = {label: loaded(hybrid, label, settle=args.settle) for label in MATERIALS}
    blocks = {"rounds": args.rounds, "per_round": args.per_round}
    constant, drag = steps(held, drag=False, **blocks), steps(held, drag=True, **blocks)
    print(f"1-2. step, {FORCE} N on a {1e3 * RADIUS:.0f} mm patch ({args.rounds} interleaved blocks of "
          f"{args.per_round} steps)")
    medians = {}
    for label in MATERIALS:
        medians[label] = np.median(constant[label]), np.median(drag[label])
        print(f"  {label:20} constant {describe(constant[label])}   drag {describe(drag[label])}   "
              f"drag / constant {medians[label][1] / medians[label][0]:.2f}")
    finite = np.divide(medians[MATERIALS[1]], medians[MATERIALS[0]])
    print(f"  neo-Hookean / linear: constant {finite[0]:.2f}, drag {finite[1]:.2f} (target <= 2)")
    return medians


def report_cuts(hybrid, args) -> dict:
    """Print section 3; ``{label: (step after, uncut step, move + step after)}`` medians [s]."""
    print(f"3. cutting ({args.moves} timed moves, a pull of {PULL_FORCE} N held beside the line)")
    medians = {}
    for label in METHODS:
        c = cutting(hybrid, label, moves=args.moves, settle=args.settle, uncut=args.per_round)
        both = np.add(c["move"], c["after"])
        uncut = np.median(c["uncut"])
        medians[label] = np.median(c["after"]), uncut, np.median(both)
        print(f"  {label:20} uncut step {describe(c['uncut'])}; {len(c['move'])} of {c['moves']} moves of "
              f"{c['edges per move']:.1f} edge lengths cut, splitting {np.median(c['split']):g} triangles each\n"
              f"  {'':20} move {describe(c['move'])}   step after {describe(c['after'])}   later steps "
              f"{describe(c['later'])}\n"
              f"  {'':20} step after / uncut {medians[label][0] / uncut:.1f} (max {np.max(c['after']) / uncut:.1f}; "
              f"target <= 2)   move + step after {describe(both)} = {medians[label][2] / FRAME:.2f} frames at 60 Hz")
    return medians


def report_grabs(hybrid, args, step_medians: dict) -> dict:
    """Print section 4; ``{(label, radius): (set_load + first step) / constant step}``."""
    print(f"4. first grab of a new node after settling (set_load + first step, {args.grabs} nodes each)")
    ratios = {}
    for label in MATERIALS:
        for radius, g in grabs(hybrid, label, count=args.grabs, settle=args.settle, between=args.per_round).items():
            grab = np.median(np.add(g["set_load"], g["first"]))
            ratios[label, radius] = grab / step_medians[label][0]
            where = "point load" if radius is None else f"{1e3 * radius:.0f} mm patch"
            print(f"  {label:20} {where:12} set_load {describe(g['set_load'])}   first step {describe(g['first'])}"
                  f"   = {ratios[label, radius]:.1f} constant steps (target <= 3), "
                  f"{grab / step_medians[label][1]:.1f} drag steps")
    return ratios


def summary(rows: dict) -> None:
    """Print section 5 from ``{size: (step medians, cut medians, grab ratios)}``."""
    linear = MATERIALS[0]
    print("\n## summary: the default hybrid (linear), ms, medians\n")
    print("| M_S vertices | constant step | drag step (target) | neo-Hookean / linear drag (<= 2) "
          "| step after a move (uncut) | step after / uncut (<= 2): " + ", ".join(METHODS) +
          " | move + step after, 60 Hz frames | first grab, 4 mm / point, in steps (<= 3) |")
    print("|---:|---:|---:|---:|---:|---|---:|---:|")
    for size, (stepped, cuts, grab) in rows.items():
        target = f" (<= {1e3 * DRAG_TARGET[size]:g})" if size in DRAG_TARGET else ""
        after, uncut, both = cuts[linear]
        cut_ratios = ", ".join(f"{a / u:.1f}" for a, u, _ in cuts.values())
        print(f"| {size} | {1e3 * stepped[linear][0]:.2f} | {1e3 * stepped[linear][1]:.2f}{target} "
              f"| {stepped[MATERIALS[1]][1] / stepped[linear][1]:.2f} | {1e3 * after:.1f} ({1e3 * uncut:.2f}) "
              f"| {cut_ratios} | {both / FRAME:.2f} | {grab[linear, RADIUS]:.1f} / {grab[linear, None]:.1f} |")
    small, large = min(rows), max(rows)
    if small < large:
        for label in MATERIALS:
            growth = np.log(rows[large][0][label][1] / rows[small][0][label][1]) / np.log(large / small)
            print(f"{label} drag step grows as n^{growth:.2f} from {small} to {large} vertices (target <= n^1.1)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=None,
                        help="sphere vertex counts (default 1000 10000; 100000 takes minutes to build)")
    parser.add_argument("--quick", action="store_true", help="the 1000-vertex sphere only, few repetitions")
    args = parser.parse_args(argv)
    args.sizes = args.sizes or ([1000] if args.quick else [1000, 10000])
    args.settle, args.rounds, args.per_round = (10, 2, 3) if args.quick else (60, 3, 10)
    args.moves, args.grabs = (5, 3) if args.quick else (8, 5)
    rows = {}
    for size in args.sizes:
        hybrid = HybridMesh.build(models.sphere(size), fine_volume=False)
        print(f"\n## sphere of {size} vertices: M_V {hybrid.volume.node_count} nodes / {hybrid.volume.element_count} "
              f"tets, mean edge {1e3 * hybrid.surface.mean_edge_length:.2f} mm\n")
        stepped = report_steps(hybrid, args)
        rows[size] = stepped, report_cuts(hybrid, args), report_grabs(hybrid, args, stepped)
    summary(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
