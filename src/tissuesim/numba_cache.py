"""Numba's on-disk cache of compiled kernels, made safe for several processes compiling at once (a study's workers
started together on a fresh machine, a test run beside a fuzz run).

Numba (0.58 to 0.68 at least) saves a kernel's compiled signature in steps that are each atomic but not together:
it reads the function's index (``*.nbi``), takes the first data-file number (``*.N.nbc``) the index does not use,
writes the index, then the data file. Two processes that compile different signatures of one kernel at once both
take number 1: the index one of them leaves names the machine code the other wrote, and every later process that
loads that signature runs code compiled for other argument types (glibc's ``free(): invalid pointer``, a segfault or
a wrong answer) until the cache is deleted. A process that loads while another saves can likewise pair a new index
with a data file left from an older version of the source. numba/numba#4807 and #10128 report the same from dask
workers.

:func:`install` makes each save (read the index, write it and the data) and each load (read both) one step under a
lock on a file of the cache folder (``fcntl.flock``: exclusive to save, shared to load). It patches Numba's cache
file class when Numba is imported, so ``import tissuesim`` still imports no Numba. Where no lock can be taken (a
read-only folder, a platform without ``fcntl``) the cache behaves as Numba's own.
"""

from __future__ import annotations

import contextlib
import importlib.abc
import importlib.util
import os
import sys
from collections.abc import Callable, Iterator
from types import ModuleType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike

try:
    import fcntl
except ImportError:          # Windows: Numba's own behaviour
    fcntl = None

#: The lock file, one per cache folder (each source folder's ``__pycache__``, or under ``NUMBA_CACHE_DIR``).
LOCK_NAME = "tissuesim-numba.lock"
_MODULE = "numba.core.caching"


@contextlib.contextmanager
def cache_lock(folder: str | None, *, exclusive: bool) -> Iterator[None]:
    """Hold the lock of the cache ``folder`` (exclusive or shared) for the ``with`` block; nothing when the lock
    file cannot be opened (no folder yet: nothing to load)."""
    try:
        handle = os.open(os.path.join(folder, LOCK_NAME), os.O_RDWR | os.O_CREAT, 0o666)
    except (OSError, TypeError):    # no folder yet, or a Numba that keeps its folder elsewhere
        yield
        return
    try:
        fcntl.flock(handle, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        yield
    finally:
        os.close(handle)        # releases the lock


def _patch(caching) -> None:
    """Wrap ``IndexDataCacheFile.save`` and ``load`` of Numba's ``caching`` module in the folder's lock (once)."""
    cache_file = getattr(caching, "IndexDataCacheFile", None)
    if cache_file is None or getattr(cache_file, "_tissuesim_locked", False):
        return      # a Numba whose cache is built otherwise keeps its own behaviour
    save, load = cache_file.save, cache_file.load

    def locked_save(self, key, data):
        with cache_lock(getattr(self, "_cache_path", None), exclusive=True):
            return save(self, key, data)

    def locked_load(self, key):
        with cache_lock(getattr(self, "_cache_path", None), exclusive=False):
            return load(self, key)

    cache_file.save, cache_file.load = locked_save, locked_load
    cache_file._tissuesim_locked = True


_after_import = []       # what runs once Numba's caching module is imported (see after_numba_import)


class _RunOnImport(importlib.abc.MetaPathFinder):
    """Finds nothing itself: when Numba's caching module is first imported, lets the other finders find it and
    runs the callbacks of :func:`after_numba_import` on it once it has run."""

    def find_spec(self, name, path, target=None):
        if name != _MODULE:
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None:
            return spec
        run = spec.loader.exec_module

        def exec_module(module):
            run(module)
            for callback in _after_import:
                callback(module)

        spec.loader.exec_module = exec_module
        return spec


def after_numba_import(callback: Callable[[ModuleType], object]) -> None:
    """Call ``callback(caching_module)`` now if Numba's caching module is loaded, else when it is (so that
    ``import tissuesim`` imports no Numba)."""
    if _MODULE in sys.modules:
        callback(sys.modules[_MODULE])
        return
    _after_import.append(callback)
    if not any(isinstance(finder, _RunOnImport) for finder in sys.meta_path):
        sys.meta_path.insert(0, _RunOnImport())


def install() -> None:
    """Lock Numba's cache saves and loads in this process: now if Numba's caching module is loaded, else when it
    is."""
    if fcntl is not None:
        after_numba_import(_patch)


def kernel_view(array: ArrayLike) -> np.ndarray:
    """A read-only view of ``array`` (no copy): Numba compiles a kernel once per argument type, and a writable and a
    read-only array are two types, so a kernel fed the surface's frozen arrays on one call and a cut's working copies
    on the next compiled again mid-session. Passing every array through this at a kernel's boundary gives it one
    type whatever the caller holds."""
    import numpy as np

    view = np.asarray(array).view()
    view.flags.writeable = False
    return view
