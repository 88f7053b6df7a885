"""The servo loop: a thread that turns the tool position into a force at a fixed rate (1 kHz by default) from the
grabbed region's local response, while the visual loop steps the full solver at its own rate and syncs.

Physics (docs/haptics.md): the grabbed node sits at x = x0 + C f under the force f [N] on it (C: its 3×3
compliance [m/N], :mod:`.response`); a virtual coupling spring of stiffness k_c [N/m] joins it to the tool point p,
f = k_c (p − a − x), with a = the tool's offset from the node at the grab (grabbing applies no force). Both hold at
once when f = (I + k_c C)⁻¹ k_c (p − a − x0): one 3×3 product per tick, its matrix computed at the grab. The device
gets −f. The spring is passive (it stores energy, never makes it) and so is the tissue's compliance, so the
coupled loop is stable for any k_c; k_c bounds the stiffness the user feels (a stiffer spring than the device can
render makes it buzz).

Threads: only the servo thread calls ``position`` and ``apply_force``; only the caller's thread (the visual loop)
calls the solver (:meth:`HapticLoop.grab`, :meth:`~HapticLoop.sync`, :meth:`~HapticLoop.release`). They share an
immutable coupling (swapped whole: an attribute store is atomic) and the latest force, copied under a lock.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass

import numpy as np

from ..errors import SolverError
from ..solvers.checks import positive_number
from .response import local_response

DEFAULT_RATE = 1000.0  # Hz: what haptic devices need for hard contact to feel crisp
#: Ticks whose start times :meth:`HapticLoop.statistics` keeps (a minute at 1 kHz).
HISTORY = 65536
#: The last part of each period [s] spent spinning on the clock instead of sleeping: a sleep overshoots by up to
#: about 0.1 ms on Linux.
SPIN = 2e-4


@dataclass(frozen=True)
class _Coupling:
    """What a tick needs: f = gain (p − anchor); never changed once published."""

    node: int
    anchor: np.ndarray  # (3,) a + x0 [m]
    gain: np.ndarray  # (3, 3) (I + k_c C)⁻¹ k_c [N/m]


@dataclass(frozen=True)
class HapticStatistics:
    """The servo thread's timing over its last :data:`HISTORY` ticks: ``ticks`` counted since :meth:`start`;
    ``rate`` [Hz] = ticks per second of that span; the interval between tick starts [s]: ``median``, ``p99``,
    ``longest``; ``late``: ticks that started more than a period late (the schedule then restarts from now)."""

    ticks: int
    rate: float
    median: float
    p99: float
    longest: float
    late: int


class HapticLoop:
    """A device-agnostic haptic loop on one solver (see the module docstring).

    Args:
        solver: a :class:`~tissuesim.solvers.base.Solver` with a static solve (any method; the FEM-based and the
            xpbd layer solve directly, and are the cheap ones to grab with).
        position: callable returning the tool position ``(3,)`` [m], called once per tick on the servo thread.
        apply_force: callable receiving the force on the tool ``(3,) float64`` [N] (−f); the array is reused by the
            next tick: copy what you keep.
        stiffness: k_c, the virtual coupling's stiffness [N/m].
        radius: the tool's contact radius R [m] (the load's patch, :meth:`Solver.set_load`), or None (one node).
        rate: ticks per second [Hz].

    Attributes:
        response: the :class:`~.response.LocalResponse` of the grabbed node, or None.
        offset: ``(3,) float64`` a [m]: the tool's offset from the grabbed node at the grab, or None.
    """

    def __init__(self, solver, *, position, apply_force, stiffness: float, radius: float | None = None,
                 rate: float = DEFAULT_RATE):
        for name, callback in (("position", position), ("apply_force", apply_force)):
            if not callable(callback):
                raise SolverError(f"{name} must be a callable (the device's {name} callback), got "
                                  f"{type(callback).__name__}; pass a function or a bound method")
        if not hasattr(solver, "solve_static"):
            raise SolverError(f"HapticLoop needs a solver (from tissuesim.make_solver), got {type(solver).__name__}")
        self.solver = solver
        self.stiffness = positive_number("coupling stiffness", stiffness, "N/m")
        self.radius = None if radius is None else positive_number("contact radius", radius, "m")
        self.period = 1.0 / positive_number("haptic rate", rate, "Hz")
        self._position, self._apply_force = position, apply_force
        self.response = None
        self.offset = None
        self._coupling: _Coupling | None = None
        self._lock = threading.Lock()
        self._latest = np.zeros(3)  # f on the tissue [N], written by ticks under the lock
        self._tool, self._pulled, self._force, self._device = (np.zeros(3) for _ in range(4))
        self._times = np.zeros(HISTORY)
        self.ticks = 0
        self._late = 0
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._error: BaseException | None = None

    # --------------------------------------------------------------------------------- the visual loop's side
    def grab(self, node: int | None = None) -> int:
        """Hold M_S ``node``, or (None) the node a :class:`~tissuesim.PinHead` would snap to from the tool
        position; returns it. Measures the node's local response (four static solves; the solver's visual state
        is put back) and starts coupling at zero force. A refused node (out of range, fixed, a patch reaching the
        support) raises the solver's error and changes nothing."""
        tool = self._read_position()
        if node is None:
            from ..interaction import PinHead

            node = PinHead(self.solver, stiffness=self.stiffness, radius=self.radius).grab(tool)
        response = local_response(self.solver, node, radius=self.radius)
        self._hold(response, tool - response.origin)
        self.solver.clear_load()
        return response.node

    def sync(self, *, relinearise: bool | None = None) -> np.ndarray:
        """Push the latest force into the solver as its load, so the surface the user sees follows the tool;
        returns it ``(3,)`` [N]. ``relinearise`` (default: with a finite-strain material) measures the local
        response again around that force (four static solves). Raises what the servo thread raised, if it
        stopped on an error."""
        self._raise_error()
        coupling = self._coupling
        if coupling is None:
            return np.zeros(3)
        with self._lock:
            force = self._latest.copy()
        self.solver.set_load(coupling.node, force, radius=self.radius)
        if relinearise is None:
            relinearise = self.solver.material != "linear"
        if relinearise:
            self._hold(local_response(self.solver, coupling.node, radius=self.radius, around=force), self.offset)
        return force

    def release(self) -> None:
        """Let go: the force drops to zero at the next tick and the solver's load is withdrawn."""
        self._coupling = None
        self.response = self.offset = None
        with self._lock:
            self._latest[:] = 0.0
        self.solver.clear_load()

    def _hold(self, response, offset: np.ndarray) -> None:
        gain = np.linalg.solve(np.eye(3) + self.stiffness * response.compliance, self.stiffness * np.eye(3))
        self.response, self.offset = response, offset
        self._coupling = _Coupling(response.node, response.origin + offset, gain)

    # ---------------------------------------------------------------------------------------- the servo side
    def tick(self) -> np.ndarray:
        """One servo tick: read the tool, compute f, hand −f to ``apply_force``; returns f on the tissue ``(3,)``
        [N] (an internal array, reused). The thread calls it every period; a test or a device's own servo
        callback may call it directly."""
        coupling = self._coupling  # one read: a grab or release in between swaps it whole
        tool, force = self._tool, self._force
        try:
            tool[:] = self._position()
        except (TypeError, ValueError):
            raise SolverError(f"the position callback must return 3 coordinates [m], got {self._position()!r}") \
                from None
        if coupling is None:
            force[:] = 0.0
        else:
            np.subtract(tool, coupling.anchor, out=self._pulled)
            np.dot(coupling.gain, self._pulled, out=force)
        if not math.isfinite(force[0] + force[1] + force[2]):
            raise SolverError(f"the haptic force is not finite ({force.tolist()} N) at tool position "
                              f"{tool.tolist()} m; the position callback must return finite metres")
        with self._lock:
            self._latest[:] = force
        np.negative(force, out=self._device)
        self._apply_force(self._device)
        return force

    def _read_position(self) -> np.ndarray:
        tool = np.asarray(self._position(), dtype=np.float64)
        if tool.shape != (3,) or not np.all(np.isfinite(tool)):
            raise SolverError(f"the position callback must return 3 finite coordinates [m], got {tool!r}")
        return tool

    # ------------------------------------------------------------------------------------------- the thread
    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> HapticLoop:
        """Start the servo thread (again, after :meth:`stop`); the tick count and timings start afresh."""
        if self.running:
            raise SolverError("the haptic loop is already running; stop() it before starting it again")
        self._stop.clear()
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
        self._raise_error()

    def __enter__(self) -> HapticLoop:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def _serve(self) -> None:
        """Tick every period: sleep most of it, spin the last :data:`SPIN` on the clock."""
        clock, period, times = time.perf_counter, self.period, self._times
        due = clock()
        try:
            while not self._stop.is_set():
                now = clock()
                times[self.ticks % HISTORY] = now
                self.ticks += 1
                self.tick()
                due += period
                now = clock()
                if now > due + period:  # fell behind (the GIL held elsewhere): no burst of catch-up ticks
                    self._late += 1
                    due = now
                if due - now > SPIN:
                    time.sleep(due - now - SPIN)
                while clock() < due:
                    pass
        except BaseException as error:  # handed to the visual loop's next sync() or stop()
            self._error = error

    def _raise_error(self) -> None:
        error, self._error = self._error, None
        if error is not None:
            raise error

    def statistics(self) -> HapticStatistics:
        """:class:`HapticStatistics` of the ticks so far (needs at least 2)."""
        count = min(self.ticks, HISTORY)
        if count < 2:
            raise SolverError(f"the haptic loop has ticked {self.ticks} time(s); statistics need at least 2")
        start = self.ticks - count
        times = np.roll(self._times, -(start % HISTORY))[:count]
        intervals = np.diff(times)
        return HapticStatistics(self.ticks, (count - 1) / (times[-1] - times[0]), float(np.median(intervals)),
                                float(np.percentile(intervals, 99)), float(intervals.max()), self._late)
