"""What the servo loops share: the coupling a tick applies, its checks and its visual-loop side (grab, sync,
release), the tick schedule and its timing statistics.

Physics (docs/haptics.md): the grabbed node sits at x = x0 + C f under the force f [N] on it (C: its 3×3
compliance [m/N], :mod:`.response`), and so do a grasper's jaws under the force f they exert on the patch they hold
(C: the patch's compliance to a rigid translation); a virtual coupling spring of stiffness k_c [N/m] joins it to the tool point p,
f = k_c (p − a − x), with a = the tool's offset from the node at the grab (grabbing applies no force). Both hold at
once when f = (I + k_c C)⁻¹ k_c (p − a − x0): one 3×3 product per tick, its matrix computed at the grab. The device
gets −f. The spring is passive (it stores energy, never makes it) and so is the tissue's compliance, up to the
hybrid's slight asymmetry (0.2–0.6 %: the coupled static model is slightly non-conservative, docs/haptics.md), so
the coupled loop is stable; k_c bounds the stiffness the user feels (a stiffer spring than the device can render
makes it buzz).
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..errors import SolverError
from ..solvers.checks import positive_number
from .tools import make_tool

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..solvers.base import Solver

DEFAULT_RATE = 1000.0  # Hz: what haptic devices need for hard contact to feel crisp
#: Ticks whose start times the statistics keep (a minute at 1 kHz).
HISTORY = 65536
#: The last part of each period [s] spent spinning on the clock instead of sleeping: a sleep overshoots by up to
#: about 0.1 ms on Linux.
SPIN = 2e-4


@dataclass(frozen=True)
class Coupling:
    """What a tick needs: f = gain (p − anchor); never changed once published. ``grab`` numbers the grab it
    belongs to (a relinearisation keeps it): a tick reports it with its force, so a force computed for an earlier
    grab never reaches the node grabbed since."""

    node: int
    anchor: np.ndarray  # (3,) a + x0 [m]
    gain: np.ndarray  # (3, 3) (I + k_c C)⁻¹ k_c [N/m]
    grab: int


@dataclass(frozen=True)
class HapticStatistics:
    """A servo loop's timing over its last :data:`HISTORY` ticks: ``ticks`` counted since it started; ``rate``
    [Hz] = ticks per second of that span; the interval between tick starts [s]: ``median``, ``p99``,
    ``longest``; ``late``: ticks that started more than a period late (the schedule then restarts from now)."""

    ticks: int
    rate: float
    median: float
    p99: float
    longest: float
    late: int


class Coupler(ABC):
    """The visual loop's side of a servo loop on one solver: checks, :meth:`grab`, :meth:`sync`, :meth:`release`.
    Subclasses publish the coupling to their servo loop and read its latest force and tool position back.

    Attributes:
        response: the :class:`~.response.LocalResponse` of the grabbed node (or of the jaws on it), or None.
        grasper: the :class:`~tissuesim.Grasper` the device holds with ``tool="grasper"`` (its ``held``, ``force``,
            ``torque`` to read), else None.
        offset: ``(3,) float64`` a [m]: the tool's offset from the grabbed node at the grab, or None (nothing
            held, or a node grabbed by index before the servo loop read the tool: nothing pulls until it has).
    """

    def __init__(self, solver: Solver, *, stiffness: float, radius: float | None, rate: float, tool: str):
        if not hasattr(solver, "solve_static"):
            raise SolverError(f"{type(self).__name__} needs a solver (from tissuesim.make_solver), got "
                              f"{type(solver).__name__}")
        self.solver = solver
        self.stiffness = positive_number("coupling stiffness", stiffness, "N/m")
        self.radius = None if radius is None else positive_number("contact radius", radius, "m")
        self.period = 1.0 / positive_number("haptic rate", rate, "Hz")
        self.response = None
        self.offset = None
        self._node = -1
        self._grab = 0  # the number of the latest grab, published with its coupling
        self._held = make_tool(tool, solver, radius=self.radius)  # its load: other loads act on beside it
        self.grasper = self._held.grasper

    def grab(self, node: int | None = None) -> int:
        """Hold M_S ``node``, or (None) the node a :class:`~tissuesim.PinHead` would snap to from the tool
        position; returns it. Measures the node's local response (four static solves; a grasper: its jaws put on
        the node, four static moves; the solver's visual state is put back), starts coupling at zero force (a force
        the servo loop computed for an earlier grab is not synced) and withdraws the tool's load (other loads on the
        solver act on). The tool position is the one the servo loop last read (see the subclass for before its
        first tick). A refused node (out of range, fixed, a patch reaching the support or holding a fixed vertex)
        raises the solver's or the grasper's error and changes nothing."""
        tool = self._tool_position()
        if tool is not None and not np.all(np.isfinite(tool)):
            raise SolverError(f"the position callback must return finite coordinates [m], got {tool.tolist()}")
        if node is None:
            if tool is None:
                raise SolverError(f"grab() snaps to the node nearest the tool, but the {type(self).__name__}'s "
                                  "servo loop has not read the tool position: start() it first, or grab a node by "
                                  "its index")
            from ..tools.pinhead import PinHead

            node = PinHead(self.solver, stiffness=self.stiffness, radius=self.radius).grab(tool)
        response = self._held.take(node)
        self._grab += 1
        self._hold(response, None if tool is None else tool - response.origin)
        return response.node

    def sync(self, *, relinearise: bool | None = None) -> np.ndarray:
        """Push the latest force into the solver as its load (a grasper: its jaws to where the force puts them,
        x0 + C f, and :meth:`Grasper.settle <tissuesim.Grasper.settle>`), so the surface the user sees follows the
        tool; returns it ``(3,)`` [N]. ``relinearise`` (default: with a finite-strain material) measures the local
        response again around that force (four static solves, or moves). Raises what the servo loop raised, if it
        stopped on an error."""
        self._raise_error()
        if self._node < 0:
            return np.zeros(3)
        force = self._latest_force()
        self._held.apply(self.response, force)
        if relinearise is None:
            relinearise = self.solver.material != "linear"
        if relinearise:
            self._hold(self._held.respond(self.response, force), self.offset)
        return force

    def release(self) -> None:
        """Let go: the force drops to zero at the next tick and the tool's load is withdrawn (a grasper lets go)."""
        self._publish(None)
        self.response = self.offset = None
        self._node = -1
        self._held.release()

    def _hold(self, response, offset: np.ndarray | None) -> None:
        """Couple the latest grab with ``response`` and ``offset`` a ``(3,)`` [m] (None: not known yet, the
        servo applies no force)."""
        self.response, self.offset, self._node = response, offset, response.node
        if offset is None:
            self._publish(None)
            return
        gain = np.linalg.solve(np.eye(3) + self.stiffness * response.compliance, self.stiffness * np.eye(3))
        self._publish(Coupling(response.node, response.origin + offset, gain, self._grab))

    @abstractmethod
    def _publish(self, coupling: Coupling | None) -> None:
        """Hand ``coupling`` (None: nothing held) to the servo loop, whole."""

    @abstractmethod
    def _latest_force(self) -> np.ndarray:
        """``(3,) float64`` the servo loop's latest force on the tissue [N], a copy; zero when it was computed for
        an earlier grab than the latest (its coupling's :attr:`Coupling.grab`)."""

    @abstractmethod
    def _tool_position(self) -> np.ndarray | None:
        """``(3,) float64`` the tool position [m] the servo loop last read, or None where it is not known."""

    @abstractmethod
    def _raise_error(self) -> None:
        """Raise what the servo loop stopped on, once."""


def coupling_force(coupling: Coupling | None, tool: np.ndarray, pulled: np.ndarray, force: np.ndarray) -> None:
    """f = gain (p − anchor) into ``force`` ``(3,)`` [N] (zero when nothing is held), ``pulled`` a workspace;
    a SolverError when it is not finite (a bad tool position)."""
    if coupling is None:
        force[:] = 0.0
    else:
        np.subtract(tool, coupling.anchor, out=pulled)
        np.dot(coupling.gain, pulled, out=force)
    if not math.isfinite(force[0] + force[1] + force[2]):
        raise SolverError(f"the haptic force is not finite ({force.tolist()} N) at tool position {tool.tolist()} m; "
                          "the position callback must return finite metres")


def read_tool(position: Callable[[], ArrayLike], tool: np.ndarray) -> None:
    """``position()`` into ``tool`` ``(3,)`` [m], or a SolverError naming what it returned."""
    value = position()  # once: a second call may return something else, or fail
    try:
        tool[:] = value
    except (TypeError, ValueError):
        raise SolverError(f"the position callback must return 3 coordinates [m], got {value!r}") from None


def serve(tick: Callable[[], object], stamp: Callable[[float, bool], None], stopping: Callable[[], bool],
          period: float) -> None:
    """Call ``stamp(now, late)`` then ``tick()`` every ``period`` [s] until ``stopping()``: sleep most of each
    period, spin the last :data:`SPIN` on the clock; a tick more than a period late restarts the schedule from
    now (no burst of catch-up ticks) and is stamped late."""
    clock = time.perf_counter
    due = clock()
    late = False
    while not stopping():
        stamp(clock(), late)
        tick()
        due += period
        now = clock()
        late = now > due + period
        if late:
            due = now
        if due - now > SPIN:
            time.sleep(due - now - SPIN)
        while clock() < due:
            pass


def statistics(times: np.ndarray, ticks: int, late: int) -> HapticStatistics:
    """:class:`HapticStatistics` from the ring ``times`` ``(HISTORY,)`` [s] of tick starts (``ticks`` so far)."""
    count = min(ticks, HISTORY)
    if count < 2:
        raise SolverError(f"the haptic loop has ticked {ticks} time(s); statistics need at least 2")
    start = ticks - count
    ordered = np.roll(times, -(start % HISTORY))[:count]
    intervals = np.diff(ordered)
    return HapticStatistics(ticks, (count - 1) / (ordered[-1] - ordered[0]), float(np.median(intervals)),
                            float(np.percentile(intervals, 99)), float(intervals.max()), late)
