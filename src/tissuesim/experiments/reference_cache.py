"""The on-disk cache of converged contact references (:mod:`.reference`): one ``<key>.npz`` per reference, written
whole (a partial ``.<key>.<pid>.npz`` renamed into place), a damaged entry recomputed, never trusted.

The contact protocol's own references also ship with the package (:data:`SHIPPED_DIR`, written by
benchmarks/contact_references.py): the same keys, compressed, the responses rounded to float32 (a relative error
below 6e-8, against the references' 1 % convergence criterion), each with :data:`SHIPPED_SCHEMA` and the parameters it
was computed for. A shipped entry is read only under the key of exactly those parameters, so a changed model, load,
material or refinement setting is computed (and cached) instead."""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
import zlib
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..errors import TissuesimError
from ..io import process_running
from .reference_data import ContactReference, LevelRow, RefinementSettings

#: The references shipped with the package, one ``<key>.npz`` each.
SHIPPED_DIR = Path(__file__).with_name("data") / "references"
SHIPPED_SCHEMA = "tissuesim-contact-reference/1"


class CacheError(TissuesimError, OSError):
    """The reference cache folder cannot be used where asked."""


def check_cache_dir(folder: Path | str) -> Path:
    """``folder`` as a Path where cache entries can be written (created if missing; tried for real), or a
    :class:`CacheError` naming it. Partial entries of killed runs are removed."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise CacheError(f"cache folder {folder} is a file, not a folder; give a folder (--cache DIR) or --no-cache")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        handle, probe = tempfile.mkstemp(prefix=".probe.", dir=folder)
    except OSError as error:
        raise CacheError(f"cannot write the reference cache in {folder}: {error.strerror or error}; give another "
                         "--cache DIR, make it writable, or pass --no-cache") from None
    os.close(handle)
    os.unlink(probe)
    _remove_abandoned_partials(folder)
    return folder


def _remove_abandoned_partials(folder: Path) -> None:
    """Remove ``.KEY.PID.npz`` partial entries whose writing process is gone (killed while writing)."""
    for path in folder.glob(".*.*.npz"):
        pid = path.name[:-len(".npz")].rsplit(".", 1)[-1]
        if pid.isdigit() and int(pid) != os.getpid() and not process_running(int(pid)):
            path.unlink(missing_ok=True)


def load_entry(cache_dir: Path | str | None, key: str, settings: RefinementSettings) -> ContactReference | None:
    """The reference cached under ``key`` in ``cache_dir``, or None where there is none or it is damaged."""
    entry = read_arrays(cache_dir, key)
    return None if entry is None else _reference(*entry, settings)


def _reference(meta: dict, data: dict, settings) -> ContactReference | None:
    try:
        return ContactReference(meta["node"], meta["radius"], data["response"], data["samples"],
                                tuple(LevelRow(**row) for row in meta["levels"]), meta["converged"],
                                meta["E"], meta["nu"], settings, data.get("nodal_response"))
    except (KeyError, TypeError):
        return None


def load_shipped(key: str, settings: RefinementSettings, folder: Path | str | None = None) -> ContactReference | None:
    """The reference shipped under ``key`` (in ``folder``, default :data:`SHIPPED_DIR`) as float64, or None where
    there is none or it is not of :data:`SHIPPED_SCHEMA`."""
    entry = read_arrays(SHIPPED_DIR if folder is None else folder, key)
    if entry is None or entry[0].get("schema") != SHIPPED_SCHEMA:
        return None
    meta, data = entry
    arrays = {name: value.astype(np.float64) if value.dtype.kind == "f" else value for name, value in data.items()}
    return _reference(meta, arrays, settings)


def ship_entry(folder: Path | str, key: str, reference: ContactReference, parameters: dict) -> Path:
    """Write ``reference`` under ``key`` in ``folder`` as a shipped entry: compressed, its responses float32, its meta
    the cache entry's plus :data:`SHIPPED_SCHEMA` and ``parameters`` (JSON-ready: what it was computed for)."""
    meta = {"schema": SHIPPED_SCHEMA, "key": key, **_meta(reference), "parameters": parameters}
    arrays = {"response": reference.response.astype(np.float32), "samples": reference.samples.astype(np.int32)}
    if reference.nodal_response is not None:
        arrays["nodal_response"] = reference.nodal_response.astype(np.float32)
    path = Path(folder) / f"{key}.npz"
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, meta=json.dumps(meta, sort_keys=True), **arrays)
    return path


def read_arrays(cache_dir: Path | str | None, key: str) -> tuple[dict, dict] | None:
    """``(meta, {name: array})`` of the entry ``key`` in ``cache_dir``, or None where there is none or it is
    damaged (truncated, foreign): such an entry is recomputed, never trusted."""
    if cache_dir is None:
        return None
    path = Path(cache_dir) / f"{key}.npz"
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            return json.loads(str(data["meta"])), {name: data[name] for name in data.files if name != "meta"}
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile, zlib.error):
        return None


def save_entry(cache_dir: Path | str | None, key: str, reference: ContactReference) -> None:
    """Cache ``reference`` under ``key`` in ``cache_dir``, whole or not at all (CacheError naming the folder)."""
    meta = _meta(reference)
    nodal = {} if reference.nodal_response is None else {"nodal_response": reference.nodal_response}
    write_arrays(cache_dir, key, meta, response=reference.response, samples=reference.samples, **nodal)


def _meta(reference: ContactReference) -> dict:
    return {"node": reference.node, "radius": reference.radius, "converged": reference.converged,
            "E": reference.youngs_modulus, "nu": reference.poisson_ratio,
            "levels": [asdict(row) for row in reference.levels]}


def write_arrays(cache_dir: Path | str | None, key: str, meta: dict, **arrays: np.ndarray) -> None:
    """Store ``meta`` (JSON-ready) and ``arrays`` under ``key`` in ``cache_dir`` (nothing where it is None), whole
    or not at all (CacheError naming the folder)."""
    if cache_dir is None:
        return
    folder = Path(cache_dir)
    partial = folder / f".{key}.{os.getpid()}.npz"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        np.savez(partial, meta=json.dumps(meta), **arrays)
        os.replace(partial, folder / f"{key}.npz")  # atomic: a reader never sees half an entry
    except OSError as error:
        partial.unlink(missing_ok=True)
        raise CacheError(f"cannot write a reference cache entry in {folder}: {error.strerror or error}; free space "
                         "there, give another --cache DIR, or pass --no-cache") from None
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
