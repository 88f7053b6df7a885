"""Saying when Numba compiles: the first run of a kernel compiles it (then it is cached on disk beside its source),
which on a fresh install costs about 20 s on 2 cores, and a silent wait that long looks like a hang.

* :func:`announce_compilation`: a ``with`` block whose compilations are announced by a :class:`CompileNotice` naming
  its caller (the command line wraps every command in one).
* :func:`install`: the library's own notice, for a script or a notebook: when Numba is imported, a listener says on
  stderr when the first of tissuesim's kernels in the process starts compiling, how far it has got every
  :data:`PROGRESS_SECONDS`, and at exit how many kernels took how long. It keeps quiet inside an
  :func:`announce_compilation` block, which says the same with its own name. A kernel loaded from the cache fires no
  compile event, so a warm run prints nothing.
"""

from __future__ import annotations

import atexit
import contextlib
import sys
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    from numba.core.event import Event

#: What the first compilation is said to cost: the first build measured 22 s on 2 cores.
COMPILE_ESTIMATE = "about 20 s"
#: The library's notice says how far it has got at most this often [s].
PROGRESS_SECONDS = 5.0

_blocks = []        # the announce_compilation blocks open now: the library's notice keeps quiet while one is


class CompileNotice:
    """Counts Numba's compilations (``numba:compile`` events; nested ones, a kernel compiling the functions it
    calls, count once); says on ``stream`` (None: stderr as it is when it speaks) when the first starts, how far it
    has got every ``progress`` seconds (None: never) and (:meth:`finish`) how many were compiled in how long."""

    def __init__(self, name: str, stream: TextIO | None, *, progress: float | None = None):
        self.name, self.stream, self.progress = name, stream, progress
        self.compiled, self.depth, self.started, self.seconds, self.said = 0, 0, 0.0, 0.0, 0.0

    def on_start(self, event: Event) -> None:
        if self.depth == 0:
            if self.compiled == 0:
                self.say(f"compiling the numerical kernels, first run only ({COMPILE_ESTIMATE}; cached for later "
                         "runs)")
            self.started = time.perf_counter()
        self.depth += 1

    def on_end(self, event: Event) -> None:
        self.depth -= 1
        if self.depth == 0:
            self.compiled += 1
            self.seconds += time.perf_counter() - self.started
            if self.progress is not None and time.perf_counter() - self.said >= self.progress:
                self.say(f"compiling: {self.compiled} kernels in {self.seconds:.0f} s so far")

    def finish(self) -> None:
        """The closing line, if anything was compiled."""
        if self.compiled:
            self.say(f"compiled {self.compiled} kernels in {self.seconds:.0f} s; the next run loads them from the "
                     "cache")

    def say(self, text: str) -> None:
        """``text`` after the notice's name on its stream (None: stderr as it is now), above any progress bar drawn
        there (tqdm's write clears and redraws it). A stream closed by now (at exit, under a test runner's capture)
        takes nothing: a notice never fails its caller."""
        from tqdm import tqdm

        stream = sys.stderr if self.stream is None else self.stream
        try:
            tqdm.write(f"{self.name}: {text}", file=stream)
            stream.flush()
        except (ValueError, OSError):
            pass
        self.said = time.perf_counter()


def _listener(on_start, on_end):
    """A Numba ``numba:compile`` listener calling ``on_start`` and ``on_end`` (Numba imported here, when used)."""
    from numba.core import event

    class Forward(event.Listener):
        def on_start(self, ev):
            on_start(ev)

        def on_end(self, ev):
            on_end(ev)

    return Forward()


@contextlib.contextmanager
def announce_compilation(name: str, stream: TextIO | None = None) -> Iterator[CompileNotice]:
    """Within the block, Numba's compilations are announced on ``stream`` (default stderr) by a
    :class:`CompileNotice` named ``name``."""
    from numba.core import event

    notice = CompileNotice(name, stream)
    listener = _listener(notice.on_start, notice.on_end)
    event.register("numba:compile", listener)
    _blocks.append(notice)
    try:
        yield notice
    finally:
        _blocks.remove(notice)
        event.unregister("numba:compile", listener)
        notice.finish()


def _library_notice() -> None:
    """Register the library's notice (once Numba is imported): quiet inside an :func:`announce_compilation`
    block, closing at exit."""
    from numba.core import event

    notice = CompileNotice("tissuesim", None, progress=PROGRESS_SECONDS)

    def start(ev):
        if not _blocks and _ours(ev):
            notice.on_start(ev)

    def end(ev):
        if not _blocks and notice.depth > 0 and _ours(ev):
            notice.on_end(ev)

    event.register("numba:compile", _listener(start, end))
    atexit.register(notice.finish)


def _ours(ev) -> bool:
    """Whether a compile event is of one of tissuesim's kernels (a user's own kernels are not announced as ours)."""
    function = getattr((ev.data or {}).get("dispatcher"), "py_func", None)
    return getattr(function, "__module__", "").startswith("tissuesim.")


def install() -> None:
    """The library's notice in this process: now if Numba is loaded, else when it is
    (:func:`tissuesim.numba_cache.after_numba_import`)."""
    from .numba_cache import after_numba_import

    after_numba_import(lambda caching: _library_notice())
