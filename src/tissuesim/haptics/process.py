"""The servo loop in a process of its own: the visual loop's solver calls hold CPython's GIL for a whole step, which
delays a servo thread in the same process (docs/haptics.md); a process has its own interpreter and GIL.

The two processes share one block of float64 (a ``RawArray``): the coupling (anchor, 3×3 gain, the grab's
number), written by the visual loop only, and the latest force, the tool position it came from and the grab it was
computed for, written by the servo process only, each behind a sequence counter (a seqlock: its one writer makes
it odd, writes, makes it even; a reader retries while it is odd or changed), and the tick times for the
statistics. The device lives in the servo process: ``device`` is a picklable callable (a module-level function or
class) that opens it there and returns its ``(position, apply_force)`` callbacks.

The servo process is started with ``spawn``: a fresh interpreter that imports the caller's main module, so a script
must start it under ``if __name__ == "__main__":`` (else its top-level code runs again in the servo process, and
multiprocessing refuses to start a process from there).
"""

from __future__ import annotations

import multiprocessing
import pickle
import time
from multiprocessing.reduction import ForkingPickler
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..errors import SolverError
from .coupling import DEFAULT_RATE, HISTORY, Coupler, Coupling, coupling_force, read_tool, serve, statistics

if TYPE_CHECKING:
    import ctypes
    from multiprocessing.queues import SimpleQueue

    from numpy.typing import ArrayLike

    from ..solvers.base import Solver
    from .coupling import HapticStatistics

    #: What a device callable returns: its ``(position, apply_force)`` callbacks.
    DeviceCallbacks = tuple[Callable[[], ArrayLike], Callable[[np.ndarray], object]]

# The shared block: [sequence, held, grab, anchor (3), gain (9)] [sequence, report: force (3), tool (3), grab]
# [ticks, late, stop] [tick start times (HISTORY)].
SEQUENCE, HELD, GRAB, ANCHOR, GAIN = 0, 1, 2, slice(3, 6), slice(6, 15)
FORCE_SEQUENCE, REPORT, TOOL = 15, slice(16, 23), slice(19, 22)
TICKS, LATE, STOP, TIMES = 23, 24, 25, slice(26, 26 + HISTORY)
BLOCK = 26 + HISTORY
#: How long [s] :meth:`HapticProcess.start` waits for the servo process's first tick (a fresh interpreter imports
#: NumPy and this package, then opens the device).
START_TIMEOUT = 60.0


class HapticProcess(Coupler):
    """A device-agnostic haptic loop on one solver, its servo loop in a process of its own (see the module
    docstring); the visual loop's side (:meth:`grab`, :meth:`sync`, :meth:`release`) is that of
    :class:`~.loop.HapticLoop`. Start it under ``if __name__ == "__main__":`` in a script: the servo process
    imports the main module afresh (``spawn``).

    The tool position lives in the servo process: ``grab()`` (by position) needs it running; ``grab(node)`` before
    :meth:`start` measures the node's response and couples it at the first tick (the offset a taken from the tool
    position that tick reads: zero force).

    Args:
        solver: a :class:`~tissuesim.solvers.base.Solver` with a static solve.
        device: a picklable callable, called once in the servo process, returning ``(position, apply_force)``:
            ``position()`` the tool position ``(3,)`` [m], ``apply_force(force)`` the force on the tool ``(3,)``
            [N] (an array reused by the next tick).
        stiffness: k_c [N/m]; radius: the contact radius R [m] or None (a grasper's reach: required); rate: ticks
            per second [Hz]; tool: ``"pin-head"`` or ``"grasper"``, as :class:`~.loop.HapticLoop`'s.
    """

    def __init__(self, solver: Solver, *, device: Callable[[], DeviceCallbacks], stiffness: float,
                 radius: float | None = None, rate: float = DEFAULT_RATE, tool: str = "pin-head"):
        if not callable(device):
            raise SolverError(f"device must be a picklable callable returning (position, apply_force), got "
                              f"{type(device).__name__}; pass a module-level function or class")
        check_picklable(device)
        super().__init__(solver, stiffness=stiffness, radius=radius, rate=rate, tool=tool)
        self.device = device
        self._coupling: Coupling | None = None
        self._block = None
        self._shared = np.zeros(BLOCK)  # until started: no ticks, nothing held
        self._process = None
        self._errors = None

    @property
    def running(self) -> bool:
        return self._process is not None and self._process.is_alive()

    @property
    def ticks(self) -> int:
        return int(self._shared[TICKS])

    def start(self) -> HapticProcess:
        """Start the servo process (again, after :meth:`stop`) and wait for its first tick; the tick count and
        timings start afresh. Raises SolverError if it stops before ticking (its device failed)."""
        if self.running:
            raise SolverError("the haptic process is already running; stop() it before starting it again")
        check_picklable(self.device)    # before anything is made (a queue's lock starts a resource tracker)
        context = multiprocessing.get_context("spawn")  # no fork of a process whose solver may hold threads
        self._block = context.RawArray("d", BLOCK)
        self._shared = np.frombuffer(self._block, dtype=np.float64)
        self._publish(self._coupling)
        self._errors = context.SimpleQueue()
        self._process = context.Process(target=serve_device, name="tissuesim-haptics", daemon=True,
                                        args=(self._block, self.device, self.period, self._errors))
        self._process.start()
        deadline = time.monotonic() + START_TIMEOUT
        while self._shared[FORCE_SEQUENCE] == 0.0 and self._process.is_alive() and time.monotonic() < deadline:
            self._process.join(0.01)  # until the first tick's report (a tick that fails ends the process)
        if self.ticks == 0:
            self.stop()
            raise SolverError(f"the haptic process did not tick within {START_TIMEOUT:g} s; check that its device "
                              "opens and that its position callback returns")
        if self.response is not None and self.offset is None and self._shared[FORCE_SEQUENCE] > 0.0:
            # grabbed by index before the tool was known: couple from where the first tick found it
            self._hold(self.response, self._reported_tool() - self.response.origin)
        return self

    def stop(self) -> None:
        """Stop the servo process and wait for it; raises what it raised, if it stopped on an error."""
        self._shared[STOP] = 1.0
        if self._process is not None:
            self._process.join(5.0)
            if self._process.is_alive():  # a device callback that never returns
                self._process.terminate()
                self._process.join()
        self._raise_error()

    def __enter__(self) -> HapticProcess:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def statistics(self) -> HapticStatistics:
        """:class:`~.coupling.HapticStatistics` of the ticks so far (needs at least 2)."""
        return statistics(self._shared[TIMES], self.ticks, int(self._shared[LATE]))

    def _publish(self, coupling: Coupling | None) -> None:
        self._coupling = coupling
        shared = self._shared
        shared[SEQUENCE] += 1.0
        shared[HELD] = coupling is not None
        if coupling is not None:
            shared[GRAB] = coupling.grab
            shared[ANCHOR] = coupling.anchor
            shared[GAIN] = coupling.gain.ravel()
        shared[SEQUENCE] += 1.0

    def _latest_force(self) -> np.ndarray:
        report = read_consistent(self._shared, FORCE_SEQUENCE, REPORT)
        return report[:3] if report[6] == self._grab else np.zeros(3)

    def _tool_position(self) -> np.ndarray | None:
        """The tool position the servo process last reported, or None while it is not running."""
        return self._reported_tool() if self.running else None

    def _reported_tool(self) -> np.ndarray:
        return read_consistent(self._shared, FORCE_SEQUENCE, TOOL)

    def _raise_error(self) -> None:
        if self._errors is not None and not self._errors.empty():
            raise SolverError(f"the haptic process stopped: {self._errors.get()}")


def check_picklable(device: object) -> None:
    """SolverError unless ``device`` can be sent to the servo process: it runs in its own process (``spawn``), which
    receives the device pickled, as ``multiprocessing`` pickles it."""
    try:
        ForkingPickler.dumps(device)
    except (pickle.PicklingError, AttributeError, TypeError) as error:
        raise SolverError(
            f"the haptic device must be picklable: the servo loop runs in its own process, which receives the "
            f"device pickled, and {type(device).__name__} {device!r:.60} cannot be ({error}); pass a module-level "
            "function or class that opens the device when called there (not a lambda, a local function or an open "
            "handle), or use HapticLoop, whose servo thread shares this process") from None


def read_consistent(shared: np.ndarray, sequence: int, part: slice) -> np.ndarray:
    """A copy of ``shared[part]`` written whole: read while the writer's ``sequence`` counter is even and
    unchanged."""
    while True:
        before = shared[sequence]
        value = shared[part].copy()
        if before % 2.0 == 0.0 and shared[sequence] == before:
            return value


def serve_device(block: ctypes.Array[ctypes.c_double], device: Callable[[], DeviceCallbacks], period: float,
                 errors: SimpleQueue[str]) -> None:
    """The servo process: open ``device``, then tick every ``period`` [s] until the block's stop flag is set; an
    error is put on ``errors`` as one line. Each tick reports its force, the tool position it read and the grab its
    coupling belongs to (0: none held)."""
    try:
        position, apply_force = device()
        shared = np.frombuffer(block, dtype=np.float64)
        times = shared[TIMES]
        tool, pulled, force, report = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(7)
        held = [None, -1.0]  # the coupling in use, the sequence it was read at

        def tick() -> None:
            sequence = shared[SEQUENCE]
            if sequence != held[1] and sequence % 2.0 == 0.0:  # a new coupling, written whole: take it
                anchor, gain, on = shared[ANCHOR].copy(), shared[GAIN].reshape(3, 3).copy(), shared[HELD]
                grab = int(shared[GRAB])
                if shared[SEQUENCE] == sequence:
                    held[:] = Coupling(-1, anchor, gain, grab) if on else None, sequence
            read_tool(position, tool)
            coupling_force(held[0], tool, pulled, force)
            report[:3], report[3:6], report[6] = force, tool, 0 if held[0] is None else held[0].grab
            shared[FORCE_SEQUENCE] += 1.0
            shared[REPORT] = report
            shared[FORCE_SEQUENCE] += 1.0
            np.negative(force, out=force)
            apply_force(force)

        def stamp(now: float, late: bool) -> None:
            times[int(shared[TICKS]) % HISTORY] = now
            shared[TICKS] += 1.0
            shared[LATE] += late

        serve(tick, stamp, lambda: shared[STOP] != 0.0, period)
    except BaseException as error:
        errors.put(f"{type(error).__name__}: {error}")
