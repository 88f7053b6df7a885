"""Running a study's cases: on a Dask cluster (each case a task, each fem reference a task of its own), or in this
process, one after the other (``client=None``: the same functions, the same answers).

The client writes each result as it arrives (:class:`~.store.Store`), so workers need no shared file system, and
an interruption (Ctrl-C, a crash, a killed worker) loses only the cases still running. A reference is computed once
per study (its task key is its content hash, so Dask shares it between the cases that need it) and kept in
``OUTPUT/references/`` for later runs.
"""

from __future__ import annotations

import os
import zipfile
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import work
from .cases import Case
from .store import Store

if TYPE_CHECKING:
    from distributed import Client

REFERENCES = "references"


@dataclass
class Summary:
    """What a run did: cases in the study, already done before, run now, and failed now."""

    cases: int
    skipped: int
    done: int = 0
    failed: int = 0


def run_study(cases: list[Case], store: Store, *, client: Client | None = None, progress: bool = True,
              on_start: Callable[[list[Case]], None] | None = None) -> Summary:
    """Run every case of ``cases`` that ``store`` does not hold yet; a failed case is written with its error.
    ``on_start``, if given, is called with the cases to run before the first starts."""
    pending = [case for case in cases if not store.done(case)]
    summary = Summary(cases=len(cases), skipped=len(cases) - len(pending))
    if on_start is not None:
        on_start(pending)
    bar = _bar(len(pending), progress)
    try:
        results = _serial(pending, store) if client is None else _distributed(pending, store, client)
        for case, result in results:
            store.write(case, result["row"], result["field"])
            failed = result["row"]["status"] == "failed"
            summary.done += not failed
            summary.failed += failed
            bar.update(1)
            bar.set_postfix(failed=summary.failed, refresh=False)
    finally:
        bar.close()
    return summary


def _serial(pending: list[Case], store: Store):
    references: dict = {}       # key -> arrays, or the error that computing them raised (not tried again)
    users = Counter(case.reference_key for case in pending if case.record.metrics)
    for case in pending:
        reference = _reference_here(case, store, references) if case.record.metrics else None
        if isinstance(reference, Exception):
            yield case, _failure(reference)
        else:
            yield case, work.run_case(case, reference)
        if case.record.metrics:
            users[case.reference_key] -= 1
            if not users[case.reference_key]:
                del references[case.reference_key]


def _reference_here(case: Case, store: Store, references: dict):
    key = case.reference_key
    if key not in references:
        references[key] = _cached(store, key)
        if references[key] is None:
            try:
                references[key] = work.reference(case)
            except Exception as error:  # noqa: BLE001 - the reference's failure is its cases'
                references[key] = error
                return error
            _keep(store, key, references[key])
    return references[key]


def _distributed(pending: list[Case], store: Store, client):
    from distributed import as_completed

    references, futures = {}, {}
    for case in pending:
        reference = None
        if case.record.metrics:
            reference = references.get(case.reference_key)
            if reference is None:
                reference = _reference_task(case, store, client)
                references[case.reference_key] = reference
        future = client.submit(work.run_case, case, reference, key=f"case-{case.case_id}", pure=False)
        futures[future.key] = (future, case)
    # a result or reference the client no longer holds is released by the cluster: memory stays bounded by the
    # cases in flight and the references still needed, not by the study's size
    users = Counter(case.reference_key for case in pending if case.record.metrics)
    try:
        for future in as_completed([f for f, _ in futures.values()]):
            case = futures.pop(future.key)[1]
            result = future.result() if future.status == "finished" else _failure(future.exception())
            yield case, result
            if case.record.metrics:
                key = case.reference_key
                _keep_future(store, key, references[key])
                users[key] -= 1
                if not users[key]:
                    del references[key]
    finally:
        client.cancel([f for f, _ in futures.values()] + [f for f in references.values() if hasattr(f, "key")])


def _reference_task(case: Case, store: Store, client):
    cached = _cached(store, case.reference_key)
    if cached is not None:
        return client.scatter(cached, hash=False)
    return client.submit(work.reference, case, key=f"reference-{case.reference_key}", pure=False)


def _keep_future(store: Store, key: str, future) -> None:
    if getattr(future, "status", None) == "finished" and not _path(store, key).exists():
        _keep(store, key, future.result())


def _failure(error) -> dict:
    return {"row": {"status": "failed", "error": f"{type(error).__name__}: {error}"}, "field": None}


def _path(store: Store, key: str) -> Path:
    return store.root / REFERENCES / f"{key}.npz"


def _cached(store: Store, key: str):
    """The reference arrays kept under ``key`` (:func:`.work.reference`), or None (also for an unreadable file,
    which is recomputed)."""
    try:
        with np.load(_path(store, key), allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile):
        return None
    return arrays if "positions" in arrays or {"response", "samples", "converged"} <= set(arrays) else None


def _keep(store: Store, key: str, arrays: dict) -> None:
    path = _path(store, key)
    path.parent.mkdir(exist_ok=True)
    temporary = path.with_name(f".{key}.{os.getpid()}.tmp.npz")
    np.savez(temporary, **arrays)
    os.replace(temporary, path)


def _bar(total: int, progress: bool):
    from tqdm import tqdm

    return tqdm(total=total, unit="case", disable=not progress, desc="cases")
