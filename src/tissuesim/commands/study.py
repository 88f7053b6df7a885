"""``tissuesim study STUDY.toml --output DIR``: a declared study (models × methods × materials × loads) run as tasks
on Dask.

The study is validated and expanded before any worker starts; the command prints how many cases, meshes and fem
references there are and the field storage. With no ``--scheduler`` it starts a ``LocalCluster`` of ``--workers``
single-threaded processes (default: one per core); with ``--scheduler tcp://host:8786`` it uses that cluster;
``--workers 0`` runs the cases in this process, one after the other. A rerun skips finished cases. At the end the
table is combined and summarised in DIR/report.md, with plots of the relative RMSE against each input the study
varies, per method.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from pathlib import Path

from .view import add_confine_argument

HELP = "run a study file (many cases) on Dask: a LocalCluster, or an existing cluster with --scheduler"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("study", type=Path, metavar="STUDY.toml", help="the study file (see docs/studies.md)")
    parser.add_argument("--output", type=Path, required=True, metavar="DIR",
                        help="the results folder (parts/, fields.zarr, results.parquet); a rerun resumes in it")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="an existing Dask scheduler, e.g. tcp://host:8786 (default: a LocalCluster)")
    parser.add_argument("--workers", type=int, default=None, metavar="N",
                        help="LocalCluster workers (default: one per core; 0: serial, in this process)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_confine_argument(parser, "study")


def run(args: argparse.Namespace) -> int:
    from ..experiments.output import check_output_folder
    from ..study.cases import expand
    from ..study.load import StudyError, read_study
    from ..study.report import write_report
    from ..study.runner import run_study
    from ..study.store import Store

    if args.workers is not None and args.workers < 0:
        raise StudyError(f"--workers must be 0 (serial) or more, got {args.workers}")
    if args.scheduler is not None and args.workers is not None:
        raise StudyError("--workers sizes the LocalCluster; an existing cluster (--scheduler) has its own workers: "
                         "give one of them")
    loaded = read_study(args.study, confine=args.confine)
    output = check_output_folder(args.output)
    cases = expand(loaded, announce=lambda count: print(f"{loaded.path.name}: {count}", file=sys.stderr))
    store = Store(output)
    print(_plan(cases), file=sys.stderr)
    client = _client(args)
    try:
        workers = 1 if client is None else len(client.scheduler_info()["workers"])
        pilot, seconds = _pilot(cases, store)
        summary = run_study(cases, store, client=client, progress=not args.quiet,
                            on_start=lambda pending: print(_estimate(pending, cases, seconds, workers),
                                                           file=sys.stderr))
        summary.done, summary.failed, summary.skipped = (summary.done + pilot.done, summary.failed + pilot.failed,
                                                         summary.skipped - pilot.done - pilot.failed)
    finally:
        if client is not None:
            client.close()
            if args.scheduler is None:
                client.cluster.close()
    report = write_report(store.combine().to_pylist(), args.output, title=loaded.study.title)
    print(f"{summary.done} cases done, {summary.failed} failed, {summary.skipped} already done before; results in "
          f"{args.output / 'results.parquet'}, summary in {report}")
    return 1 if summary.failed else 0


def _plan(cases) -> str:
    """The study's size, before it starts: cases, distinct meshes and references, and the field storage."""
    import numpy as np

    meshes = {case.model.key for case in cases}
    references = {case.reference_key for case in cases if case.record.metrics}
    fields = [case for case in cases if case.record.field]
    text = (f"{_count(len(cases), 'case')} on {_count(len(meshes), 'mesh')}, "
            f"{_count(len(references), cases[0].reference[0] + ' reference')}; each worker builds a mesh and its "
            "solvers once")
    if fields:
        # a built-in model's resolution is its vertex count; a file's is unknown until it is read
        known = [case.model.resolution for case in fields if case.model.resolution]
        if known:
            text += f"; fields ≈ {len(fields) * np.mean(known) * 12 / 1e6:.3g} MB of float32 in Zarr"
    return text


def _pilot(cases, store):
    """The first case still to run, run here before the others, and its wall time [s] (None when fewer than two
    cases are left): the estimate rests on a case measured now, its reference, mesh and kernels included, so it errs
    high; not on the cases found done, whose recorded times leave those out. Its result is kept like any other."""
    from ..study.runner import Summary, run_study

    pending = [case for case in cases if not store.done(case)]
    if len(pending) < 2:
        return Summary(cases=0, skipped=0), None
    start = time.perf_counter()
    summary = run_study(pending[:1], store, progress=False)
    return summary, time.perf_counter() - start


def _estimate(pending, cases, seconds, workers: int) -> str:
    """How many cases are left, and their time at ``seconds`` a case (the pilot's), if measured."""
    text = f"{len(pending)} to run, {len(cases) - len(pending)} already done"
    if pending and seconds is not None:
        text += (f"; about {_duration(seconds * len(pending) / max(workers, 1))} on {_count(workers, 'worker')} at "
                 f"the time of the case just run here ({seconds:.3g} s)")
    elif pending:
        text += f" on {_count(workers, 'worker')}; the bar gives the time left once the first cases finish"
    return text


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else (f"{seconds / 60:.0f} min" if seconds < 7200
                                                     else f"{seconds / 3600:.1f} h")


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" + ("" if n == 1 else ("es" if noun.endswith("sh") else "s"))


def _client(args):
    if args.workers == 0:
        return None
    from distributed import Client, LocalCluster

    if args.scheduler is not None:
        client = Client(args.scheduler)
    else:
        workers = args.workers or os.cpu_count() or 1
        # A case or reference that a worker refuses is recorded in its row, with its message; the worker's own log
        # of it ("Compute Failed" and a traceback) would only repeat it as a traceback.
        client = Client(LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                     silence_logs=logging.CRITICAL))
    print(f"Dask dashboard: {client.dashboard_link}", file=sys.stderr)
    return client
