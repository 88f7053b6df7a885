"""The servo thread: turns the tool position into a force at a fixed rate (1 kHz by default) from the grabbed
region's local response, while the visual loop steps the full solver at its own rate and syncs (the physics:
:mod:`.coupling`).

Threads: only the servo thread calls ``position`` and ``apply_force``; only the caller's thread (the visual loop)
calls the solver (:meth:`~.coupling.Coupler.grab`, :meth:`~.coupling.Coupler.sync`,
:meth:`~.coupling.Coupler.release`). They share an immutable coupling (swapped whole: an attribute store is atomic)
and what a tick computed (the force, the grab it was computed for, the tool position it read), copied under a lock;
a grab snaps from that tool position. The one exception: with no tick since the loop was made or stopped (a grab
before :meth:`HapticLoop.start`, as in the package's example), no thread reads the device, so the grab calls
``position`` once on the caller's thread; a device that may be read only in its servo callback must tick first.
CPython's GIL lets one thread run Python at a time, so a solver step that holds it delays the ticks
(docs/haptics.md measures by how much); :class:`~.process.HapticProcess` runs the servo loop in a process of its
own instead.
"""

from __future__ import annotations

import threading
import time
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..errors import SolverError
from .coupling import DEFAULT_RATE, HISTORY, Coupler, Coupling, coupling_force, read_tool, serve, statistics

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..solvers.base import Solver
    from .coupling import HapticStatistics

#: How long [s] a grab waits for a just started servo thread's first reading of the tool.
FIRST_TICK_TIMEOUT = 5.0


class HapticLoop(Coupler):
    """A device-agnostic haptic loop on one solver, its servo loop on a thread (see the module docstring).

    Args:
        solver: a :class:`~tissuesim.solvers.base.Solver` with a static solve (any method; the FEM-based and the
            xpbd layer solve directly, and are the cheap ones to grab with).
        position: callable returning the tool position ``(3,)`` [m], called once per tick on the servo thread (and
            once by a grab before any tick, on the caller's thread).
        apply_force: callable receiving the force on the tool ``(3,) float64`` [N] (−f); the array is reused by the
            next tick: copy what you keep.
        stiffness: k_c, the virtual coupling's stiffness [N/m].
        radius: the tool's contact radius R [m] (the load's patch, :meth:`Solver.add_load`), or None (one node);
            a grasper's reach (required).
        rate: ticks per second [Hz].
        tool: what the device holds: ``"pin-head"`` (a force on the grabbed node's patch) or ``"grasper"`` (jaws
            carrying the patch within ``radius`` of the node rigidly, :class:`~tissuesim.Grasper`).

    Attributes (besides :class:`~.coupling.Coupler`'s):
        ticks: ticks of the servo thread since :meth:`start` (direct :meth:`tick` calls are not counted).
    """

    def __init__(self, solver: Solver, *, position: Callable[[], ArrayLike],
                 apply_force: Callable[[np.ndarray], object], stiffness: float, radius: float | None = None,
                 rate: float = DEFAULT_RATE, tool: str = "pin-head"):
        for name, callback in (("position", position), ("apply_force", apply_force)):
            if not callable(callback):
                raise SolverError(f"{name} must be a callable (the device's {name} callback), got "
                                  f"{type(callback).__name__}; pass a function or a bound method")
        super().__init__(solver, stiffness=stiffness, radius=radius, rate=rate, tool=tool)
        self._position, self._apply_force = position, apply_force
        self._coupling: Coupling | None = None
        self._lock = threading.Lock()
        self._latest = np.zeros(3)  # f on the tissue [N], written by ticks under the lock
        self._latest_grab = 0  # the grab it was computed for (0: none)
        self._latest_tool = np.zeros(3)  # the tool position it was computed from [m]
        self._ticked = threading.Event()  # set by a tick: _latest_tool holds a reading; cleared by start and stop
        self._tool, self._pulled, self._force, self._device = (np.zeros(3) for _ in range(4))
        self._times = np.zeros(HISTORY)
        self.ticks = 0
        self._late = 0
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._error: BaseException | None = None

    def tick(self) -> np.ndarray:
        """One servo tick: read the tool, compute f, hand −f to ``apply_force``; returns f on the tissue ``(3,)``
        [N] (an internal array, reused). The thread calls it every period; a device's own servo callback (or a
        test) may call it directly."""
        coupling = self._coupling  # one read: a grab or release in between swaps it whole
        read_tool(self._position, self._tool)
        coupling_force(coupling, self._tool, self._pulled, self._force)
        with self._lock:
            self._latest[:] = self._force
            self._latest_grab = 0 if coupling is None else coupling.grab
            self._latest_tool[:] = self._tool
        if not self._ticked.is_set():
            self._ticked.set()
        np.negative(self._force, out=self._device)
        self._apply_force(self._device)
        return self._force

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> HapticLoop:
        """Start the servo thread (again, after :meth:`stop`); the tick count and timings start afresh."""
        if self.running:
            raise SolverError("the haptic loop is already running; stop() it before starting it again")
        self._stop.clear()
        self._ticked.clear()
        self._error = None
        self.ticks, self._late = 0, 0
        self._thread = threading.Thread(target=self._serve, name="tissuesim-haptics", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the servo thread and wait for it; raises what it raised, if it stopped on an error."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        self._ticked.clear()  # the device is no longer read: a grab reads it afresh
        self._raise_error()

    def __enter__(self) -> HapticLoop:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def statistics(self) -> HapticStatistics:
        """:class:`~.coupling.HapticStatistics` of the ticks so far (needs at least 2)."""
        return statistics(self._times, self.ticks, self._late)

    def _serve(self) -> None:
        try:
            serve(self.tick, self._stamp, self._stop.is_set, self.period)
        except BaseException as error:  # handed to the visual loop's next sync() or stop()
            self._error = error

    def _stamp(self, now: float, late: bool) -> None:
        self._times[self.ticks % HISTORY] = now
        self.ticks += 1
        self._late += late

    def _publish(self, coupling: Coupling | None) -> None:
        self._coupling = coupling

    def _latest_force(self) -> np.ndarray:
        with self._lock:
            if self._latest_grab != self._grab:
                return np.zeros(3)
            return self._latest.copy()

    def _tool_position(self) -> np.ndarray:
        """The tool position the latest tick read; before any tick (none since the loop was made or stopped),
        ``position()`` once on the caller's thread, no other thread reading the device then."""
        deadline = time.monotonic() + FIRST_TICK_TIMEOUT
        while self.running and not self._ticked.wait(0.01):
            if time.monotonic() > deadline:
                raise SolverError(f"the haptic loop's servo thread has not read the tool position within "
                                  f"{FIRST_TICK_TIMEOUT:g} s; check that its position callback returns")
        if self._ticked.is_set():
            with self._lock:
                return self._latest_tool.copy()
        tool = np.zeros(3)
        read_tool(self._position, tool)
        return tool

    def _raise_error(self) -> None:
        error, self._error = self._error, None
        if error is not None:
            raise error
