"""Cost of running a study through the engine: per-case overhead against a plain loop, and the speed-up of two Dask
workers over the serial run, on the surrogate-dataset study (random pin-head loads → displacement fields).

    PYTHONPATH=src python benchmarks/bench_study.py --cases 300 --resolution 1000 \
        --figure docs/figures/study_throughput.png
    PYTHONPATH=src python benchmarks/bench_study.py --cases 40 --resolution 1000 --timing-steps 2000 \
        --figure docs/figures/study_throughput_heavy.png

Prints figures and ratios; asserts nothing. Wall times of this machine (two cores shared with other jobs: the
speed-up of two workers is bounded by 2 and by what else runs). Each run starts from an empty output folder.

1. **plain loop**: one mesh, one solver, then for each load its draw, ``solve_static`` and the displacement field
   (what a user would write by hand, nothing stored);
2. **engine, serial** (``--workers 0``): the same cases through :func:`tissuesim.study.runner.run_study`, which
   also hashes each case, writes its Parquet part and its Zarr field, and combines the table;
3. **engine on a LocalCluster** of 1 and 2 single-threaded worker processes (cluster start-up and the workers'
   imports excluded; each worker's mesh build included, as in a real study);
4. **the ceiling**: two processes running equal pure-CPU loads at once against one running one, measured right
   after, so a speed-up below 2 can be read against what the machine's cores gave at that moment.
"""

from __future__ import annotations

import argparse
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

from tissuesim.experiments import protocol
from tissuesim.study import work
from tissuesim.study.cases import expand
from tissuesim.study.load import parse_study
from tissuesim.study.runner import run_study
from tissuesim.study.store import Store

STUDY = """
title = "surrogate dataset"
[[models]]
name = "cube"
resolution = {resolution}
[[methods]]
name = "hybrid"
[loads]
radius = 0.008
[loads.random]
count = {cases}
seed = 1
force = [0.5, 2.0]
[record]
metrics = {metrics}
field = true
step_times = {step_times}
timing_steps = {timing_steps}
"""


def plain_loop(cases) -> float:
    """Seconds of the hand-written loop over ``cases`` (mesh and solver built once, inside the timing)."""
    start = time.perf_counter()
    solver = None
    for case in cases:
        solver = solver or work.solver_of(case.model, case.method, case.options, case.material)
        node, force = work.load_of(case, solver.hybrid)
        positions = solver.solve_static(node, force, radius=case.radius)
        np.asarray(positions - solver.rest_positions, dtype=np.float32)
        if case.record.metrics:
            reference = work.reference(case)
            nodes = protocol.sample_nodes(solver.rest_positions, node, case.record.samples)
            protocol.rmse(positions, reference, nodes)
        if case.record.step_times:
            work._median_step_ms(solver, case.record.timing_steps)
    return time.perf_counter() - start


def engine(cases, client) -> float:
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        summary = run_study(cases, Store(Path(folder)), client=client, progress=False)
        Store(Path(folder)).combine()
        elapsed = time.perf_counter() - start
    assert summary.done == len(cases), summary
    return elapsed


def on_cluster(cases, workers: int) -> float:
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with Client(cluster) as client:
            client.run(__import__, "tissuesim.study.work")      # start-up (imports) is not per-study work
            return engine(cases, client)


def _busy(_) -> float:
    """A fixed pure-Python CPU load [s of wall time]: the same work in every process."""
    start = time.perf_counter()
    total = 0
    for i in range(15_000_000):
        total += i * i % 7
    return time.perf_counter() - start


def capacity() -> float:
    """Two equal CPU loads in two pool processes at once against one load in one (× 2), now: the ceiling of any
    two-worker speed-up on this machine at this moment (2 on two idle cores). Both in pool processes: a loop runs
    ~20 % faster there than in this process, which has imported the whole library."""
    from multiprocessing import Pool

    with Pool(2) as pool:
        pool.map(_busy, [0])                       # the pool's start-up, not timed
        start = time.perf_counter()
        pool.map(_busy, [0])
        one = time.perf_counter() - start
        start = time.perf_counter()
        pool.map(_busy, [0, 1], chunksize=1)
        return 2 * one / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=64)
    parser.add_argument("--resolution", type=int, default=400)
    parser.add_argument("--metrics", action="store_true",
                        help="measure each case against its fem reference (a task of its own: heavier cases)")
    parser.add_argument("--timing-steps", type=int, default=0,
                        help="also time this many steps per case (CPU-heavy cases, where the engine's cost is small)")
    parser.add_argument("--figure", type=Path, default=None)
    args = parser.parse_args()
    cases = expand(parse_study(STUDY.format(cases=args.cases, resolution=args.resolution,
                                                metrics=str(args.metrics).lower(),
                                                step_times=str(args.timing_steps > 0).lower(),
                                                timing_steps=max(args.timing_steps, 1)), Path("study.toml")))
    work.CACHE["meshes"].clear()
    work.CACHE["solvers"].clear()
    times = {"plain loop": plain_loop(cases)}
    work.CACHE["meshes"].clear()
    work.CACHE["solvers"].clear()
    times["engine, serial"] = engine(cases, None)
    times["Dask, 1 worker"] = on_cluster(cases, 1)
    times["Dask, 2 workers"] = on_cluster(cases, 2)
    n = len(cases)
    nodes = work.hybrid_of(cases[0].model).surface.vertex_count
    against = ", each against its fem reference" if args.metrics else ""
    print(f"{n} random pin-head cases on a {nodes}-node cube (hybrid{against}), field {nodes * 12 / 1e3:.1f} kB "
          "each")
    for name, seconds in times.items():
        print(f"  {name:16s} {seconds:7.2f} s  {n / seconds:7.1f} cases/s  {1e3 * seconds / n:7.2f} ms/case")
    plain, serial = times["plain loop"], times["engine, serial"]
    print(f"engine overhead per case (serial - plain) / n: {1e3 * (serial - plain) / n:.2f} ms")
    print(f"Dask overhead per case (1 worker - serial) / n: {1e3 * (times['Dask, 1 worker'] - serial) / n:.2f} ms")
    print(f"speed-up of 2 workers over serial: {serial / times['Dask, 2 workers']:.2f}x, over 1 worker: "
          f"{times['Dask, 1 worker'] / times['Dask, 2 workers']:.2f}x")
    ceiling = capacity()
    print(f"ceiling now: two processes ran two equal CPU loads {ceiling:.2f}x faster than one process in turn")
    if args.figure is not None:
        heavy = f", {args.timing_steps} steps timed each" if args.timing_steps else ""
        _figure(times, f"{n} random pin-head loads on a {nodes}-node cube{heavy}, fields stored; 2 workers "
                       f"{serial / times['Dask, 2 workers']:.2f}x serial where the cores allowed {ceiling:.2f}x",
                args.figure)


def _figure(times: dict, title: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.2))
    names = list(times)
    n = int(title.split()[0])
    rates = [n / times[name] for name in names]
    bars = ax.barh(names[::-1], rates[::-1], color=["#4c72b0", "#4c72b0", "#dd8452", "#55a868"][::-1])
    for bar, rate in zip(bars, rates[::-1]):
        ax.text(bar.get_width(), bar.get_y() + bar.get_height() / 2, f" {rate:.1f}", va="center")
    ax.set_xlabel("cases per second (higher is better)")
    ax.set_title(textwrap.fill(title, 64), fontsize=10)
    ax.set_xlim(0, max(rates) * 1.2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
