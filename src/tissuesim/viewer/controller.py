"""The simulator's interaction logic, without any window: pointer and key events in, Grasper / PinHead / Scalpel calls
out.

A window layer (:mod:`tissuesim.viewer.app`) turns mouse events into *pointer events* — the picked surface point
under the cursor (or None) and the camera ray through it — and calls :meth:`Controller.advance` once per frame
with the wall time that passed. Everything else happens here, so it is tested without OpenGL:

* **grasper mode** (what the simulator starts in: ``tissuesim view`` passes ``mode="grasper"``): pointer down on the
  surface closes jaws (:class:`~.tools.GrasperTool`) on the vertices within their reach; moving carries the jaws in
  the camera plane, and the held patch goes exactly where they go (each step settles it there first), the force on
  them being the output; pointer up lets go, with the hold modifier they keep holding, so several hold at once;
* **pin-head mode** (the paper's, §8.2): pointer down on the surface snaps the pin-head to the nearest M_S node
  (:meth:`PinHead.grab`); moving drags the cursor in the *camera plane* (the plane through the grab point facing
  the camera), so f = k (x − x0) (eq 24) lies in the screen plane as on a haptic-free desktop; pointer up releases;
* **a second hand**: a pin-head let go with the hold modifier (Shift in the window) keeps its load, clamped where it
  was let go (:class:`~.tools.HeldPins`), so the user can hold a fold and then grab again or cut beside it; X lets go
  of every held pin-head, grasper and probe;
* **probe mode**: a rigid sphere (:class:`~.tools.ProbeTool`) pressed where the pointer touches the surface and slid
  across it while the button is down; with Shift on release it stays pressing;
* **support mode**: a stroke paints the fixed region (:class:`~.tools.SupportBrush`); when it ends the solver is
  rebuilt over the same mesh with those vertices fixed (a region that leaves the body free is refused, saying why);
* **scalpel mode** (§8.4): pointer down, move and up call ``Scalpel.press / move / release``, with the picked
  surface point lifted toward the camera by :data:`BLADE_LIFT` of the blade depth, so the blade (along the inward
  normal) sweeps across the surface (off the surface: the camera-plane point through the last blade point);
* **settings** (method, E, ν, k, contact radius, iterations, dt, prestrain) change live: a change that alters the
  solver (method, material, iterations, prestrain) builds a new one over the current mesh and re-applies a held
  pin-head, the graspers' holds and the probe;
* **time**: the simulation runs at its own fixed dt (:meth:`advance`), as many steps as the wall time asks, at most
  :data:`MAX_STEPS_PER_FRAME` steps and :data:`STEP_BUDGET` seconds per frame so a slow method never freezes the
  window; when one step takes longer than dt of wall time the simulation is slower than real time and
  :attr:`FrameStats.behind` says so.

Choices where the paper is silent: the default pin-head stiffness :data:`~.settings.DEFAULT_STIFFNESS` [N/m] (a 2 cm
drag is 1 N, the middle of the experiments' 0.5–20 N range; ``tissuesim view`` sizes it to the model instead,
:func:`~.settings.sized_defaults`); a grab that misses every node within the snap radius leaves
the pin-head free and says why in :attr:`Controller.notice`, instead of raising into the window loop; so does a grab
the grasper refuses (nothing in reach, a fixed vertex, a vertex other jaws hold), and a refused carry leaves the jaws
where they were.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..errors import SolverError, TissuesimError
from ..tools.pinhead import PinHead
from ..solvers.checks import checked_point
from .building import SolverBuilding, extra_options
from .settings import Settings, checked_settings
from .rays import camera_plane_point, unit_ray
from .tools import BRUSH_EDGES, GRASP_EDGES, GrasperTool, HeldPins, ProbeTool, SupportBrush

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..mesh.hybrid import HybridMesh
    from ..tools.scalpel import Scalpel
    from ..solvers.base import Solver
    from .playback import ScenePlayback

MAX_STEPS_PER_FRAME = 25  # a frame never runs more steps than this (0.25 s of simulated time at 10 ms) ...
STEP_BUDGET = 0.1  # s ... nor steps for longer than this, so the window stays responsive
BLADE_LIFT = 0.3  # of the blade depth: the tip is held this far above the picked point, toward the camera, so
# that every sweep of the blade crosses the surface (a tip exactly on it would sweep only just below it)
PROBE_EDGES = 3.0  # the probe's default radius in mean rest edge lengths: larger than the triangles it presses
SMOOTHING = 0.1  # weight of the newest sample in the running means of step time and frame rate
MODES = ("grasper", "pin", "probe", "scalpel", "support")
#: The modes whose press takes hold of the tissue (the window drags only after a press that held).
HANDS = ("grasper", "pin")


@dataclass(frozen=True)
class FrameStats:
    """What :meth:`Controller.advance` did this frame.

    Attributes:
        steps: simulation steps run. step_seconds: mean wall time of one step [s] (running mean).
        behind: True when a step takes longer than dt, i.e. the simulation runs slower than real time.
        dropped: simulated time [s] given up this frame because the frame's step budget was spent.
    """

    steps: int
    step_seconds: float
    behind: bool
    dropped: float


def scalpel_class() -> type[Scalpel] | None:
    """The Scalpel class, or None where this installation has none (scalpel mode is then unavailable)."""
    try:
        from ..tools.scalpel import Scalpel
    except ImportError:
        return None
    return Scalpel


class Controller(SolverBuilding):
    """Interaction logic of the simulator over one hybrid mesh.

    Args:
        hybrid: the :class:`~tissuesim.mesh.hybrid.HybridMesh` to simulate (kept for :meth:`reset`).
        settings: initial :class:`Settings`.
        solver_options: further keyword options of :func:`~tissuesim.solvers.registry.make_solver` given to every
            solver the controller builds (e.g. ``fixed``, ``gravity``, ``attachments``, ``density`` from a scene
            file); the options :class:`Settings` holds (E, ν, dt, ...) are refused here.
        scalpel_factory: ``solver -> scalpel`` with press / move / release (and, optionally, prepare: called when
            the scalpel is picked up); default: ``tissuesim.Scalpel`` where
            installed, else scalpel mode is unavailable.
        playback: a scene's scripted tools (:class:`~.playback.ScenePlayback`), played before each step until the
            user's own press takes over; None (default) for none.
        mode: the tool to start with, one of :data:`MODES` (default ``"pin"``, the paper's pin-head; the simulator's
            window starts with the grasper).
        clock: seconds, monotonic (injectable for tests).

    Attributes:
        solver, pin (PinHead), grasper (:class:`~.tools.GrasperTool`), scalpel (or None), mode (one of
        :data:`MODES`), paused, settings, notice (a line for
        the user or ""), cursor (``(3,)`` pin-head position [m] or None), force (``(3,)`` current pin-head force [N]),
        last_cut (the last report the scalpel returned, or None), held (:class:`~.tools.HeldPins`: pin-heads left
        holding), brush (:class:`~.tools.SupportBrush`), support (``(k,) int32`` the painted fixed vertices, or None:
        the ``fixed`` of ``solver_options``, else the model's bottom).
    """

    def __init__(self, hybrid: HybridMesh, *, settings: Settings = Settings(),
                 solver_options: Mapping[str, object] | None = None,
                 scalpel_factory: Callable[[Solver], Scalpel] | None = None,
                 clock: Callable[[], float] = time.perf_counter, playback: ScenePlayback | None = None,
                 mode: str = "pin"):
        if mode not in MODES:
            raise SolverError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
        self.hybrid = hybrid
        self.playback = playback
        self.solver_options = extra_options(solver_options)
        self.held = HeldPins()
        self.brush = SupportBrush(hybrid.surface)
        self.probe = ProbeTool(radius=PROBE_EDGES * self.brush.radius / BRUSH_EDGES)
        self.grasper = GrasperTool(radius=GRASP_EDGES * self.brush.radius / BRUSH_EDGES)
        self.support: np.ndarray | None = None
        self.clock = clock
        self._scalpel_factory = scalpel_class() if scalpel_factory is None else scalpel_factory
        self.mode = mode
        self._hand = mode if mode in HANDS else HANDS[0]    # the hand tool S goes back to: the one used last
        self.paused = False
        self.notice = ""
        self.cursor: np.ndarray | None = None
        self.force = np.zeros(3)
        self.last_cut = None
        self._cutting = False
        self._blade: np.ndarray | None = None
        self._debt = 0.0
        self._step_seconds = 0.0
        self.settings = checked_settings(settings)
        self._build(hybrid)

    # ---------------------------------------------------------------------------------------------- properties
    @property
    def scalpel_available(self) -> bool:
        """Whether scalpel mode works with the current method (else :meth:`set_mode` says why not)."""
        return self.scalpel is not None

    @property
    def holding(self) -> bool:
        """Whether the hand tool holds what the press took (the grasper's patch, the pin-head's node)."""
        return self.grasper.grasping if self.mode == "grasper" else self.mode == "pin" and self.pin.grabbed

    @property
    def force_newtons(self) -> float:
        """|f| of the pin-head [N]."""
        return float(np.linalg.norm(self.force))

    # ----------------------------------------------------------------------------------------------- pointer
    def pointer_down(self, hit: ArrayLike | None, ray_origin: ArrayLike, ray_direction: ArrayLike) -> None:
        """Button down: ``hit`` ``(3,)`` picked surface point [m] or None; the camera ray through the cursor.

        A bad event (a hit or ray that is not 3 finite numbers) changes nothing and says why in :attr:`notice`."""
        self.notice = ""
        if hit is None:
            return
        took_over = self.playback is not None and self.playback.take_over()
        try:
            hit = checked_point(hit).copy()
            if self.mode == "grasper":
                self.grasper.grab(self.solver, hit)
            elif self.mode == "pin":
                self.pin.grab(hit)
                self.notice = self.pin.notice  # the grab may have held a farther node than the one clicked: say so
                self.cursor, self.force = hit, np.zeros(3)
            elif self.mode == "support":
                self.brush.paint(hit, self.solver.positions)
            elif self.mode == "probe":
                self.probe.press(self.solver, hit, ray_direction)
            else:
                tip = self._lifted(hit, ray_direction)
                self.last_cut = self.scalpel.press(tip)  # the blade along the inward normal there
                self._cutting, self._blade = True, tip
        except TissuesimError as error:
            self.notice = str(error)
        if took_over and not self.notice:
            self.notice = "you took over from the scene's script (R plays it again from the start)"

    def pointer_move(self, hit: ArrayLike | None, ray_origin: ArrayLike, ray_direction: ArrayLike) -> None:
        """Cursor moved: drag the grasper's jaws or the held pin-head in the camera plane, or move the blade.

        A drag the pin-head refuses (a bad ray, a force too large to hold) keeps the hold and the last force and
        says why in :attr:`notice`; a refused cut lifts the blade (:meth:`_move_blade`)."""
        try:
            if self.mode == "grasper":
                self.grasper.drag(ray_origin, ray_direction)
            elif self.mode == "pin":
                self._drag_pin(hit, ray_origin, ray_direction)
            elif self.mode == "probe":
                self.probe.drag(ray_origin, ray_direction)
            elif self.mode == "support":
                if self.brush.painting and hit is not None:
                    self.brush.paint(hit, self.solver.positions)
            elif self._cutting:
                if hit is not None:
                    point = self._lifted(checked_point(hit), ray_direction)
                else:
                    point = camera_plane_point(ray_origin, ray_direction, self._blade)
                if point is not None:
                    self._move_blade(np.asarray(point, dtype=np.float64))
        except TissuesimError as error:
            self.notice = f"the drag was refused: {error}"

    def _drag_pin(self, hit, ray_origin, ray_direction) -> None:
        if not self.pin.grabbed:
            self.cursor = None if hit is None else checked_point(hit).copy()
            return
        point = camera_plane_point(ray_origin, ray_direction, self.pin.anchor)
        if point is not None:
            self.force = self.pin.drag(point)  # raises before the load changes (a refused load changes nothing)
            self.cursor = point

    def _move_blade(self, point: np.ndarray) -> None:
        """Cut on to ``point`` ``(3,)`` [m]; a refused move lifts the blade and says why in :attr:`notice` (the
        window's frame callback must not die with a cut, and the next drag would only be refused again)."""
        try:
            self.last_cut = self.scalpel.move(point)
        except TissuesimError as error:
            self.scalpel.release()
            self._cutting = False
            self.notice = f"the cut stopped here: {error}; press again to cut on"
            return
        self._blade = point

    def pointer_up(self, *, hold: bool = False) -> None:
        """Button up: the grasper lets go, or releases the pin-head (the force goes; with ``hold``, either stays
        holding where it is and the next press takes a new one), fix the painted region, or lift the blade."""
        if self.mode == "grasper":
            self.grasper.let_go(hold=hold)
        elif self.mode == "pin":
            if hold and self.pin.grabbed and self.cursor is not None:
                self.held.hold(self.pin, self.cursor)
                self.pin = PinHead(self.solver, stiffness=self.settings.stiffness, radius=self.settings.radius)
            else:
                self.pin.release()
            self.force = np.zeros(3)
        elif self.mode == "support":
            if self.brush.painting and self.brush.paints == "ligament":
                self.add_ligament(self.brush.finish(), stiffness=self.brush.ligament_stiffness)
            elif self.brush.painting:
                self.set_support(self.brush.finish())
        elif self.mode == "probe":
            self.probe.let_go(hold=hold)
        elif self._cutting:
            self.last_cut = self.scalpel.release()
            self._cutting = False

    def key(self, name: str) -> None:
        """Keyboard: "s" switches the hand tool (grasper or pin-head) / scalpel, "x" lets go of everything held, "r"
        resets, "space" pauses and resumes."""
        actions = {"s": self.toggle_mode, "x": self.release_held, "r": self.reset, "space": self.toggle_pause}
        if not isinstance(name, str):
            self.notice = f"a key is named by a string (s, x, r, space), got {name!r}; ignored"
        elif name in actions:  # every key of a keyboard arrives here: other names are ignored quietly
            actions[name]()

    # ---------------------------------------------------------------------------------------------- commands
    def toggle_mode(self) -> None:
        """The scalpel from any other mode, and from the scalpel back to the hand tool used last (grasper or
        pin-head)."""
        self.set_mode(self._hand if self.mode == "scalpel" else "scalpel")

    def set_mode(self, mode: str) -> None:
        if mode not in MODES:
            raise SolverError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
        if mode == "scalpel" and self.scalpel is None:
            self.notice = self._no_scalpel
            return
        self.pointer_up()  # never leave a load or a cut dangling across a mode switch
        self.mode = mode
        if mode in HANDS:
            self._hand = mode
        if mode == "scalpel":
            self._prepare_scalpel()

    def toggle_pause(self) -> None:
        self.paused = not self.paused

    def release_held(self) -> None:
        """Every pin-head and grasper left holding lets go, and the probe."""
        self.held.release_all()
        self.grasper.release_all()
        self.probe.release()

    def reset(self) -> None:
        """Back to the uncut mesh at rest, without load; a scene's script plays again from its start."""
        if self.playback is not None:
            self.playback.restart()
        self._build(self.hybrid)

    def advance(self, elapsed: float) -> FrameStats:
        """Run the simulation steps that ``elapsed`` [s] of wall time ask for (at most MAX_STEPS_PER_FRAME).

        ``elapsed`` must be finite and at least 0 (SolverError otherwise, with nothing changed): a NaN or an
        infinite time owed would stop the simulation for good."""
        elapsed = self._frame_time(elapsed)
        dt = self.settings.dt
        if self.paused:
            return FrameStats(0, self._step_seconds, False, 0.0)
        self._debt += elapsed
        steps, began = 0, self.clock()
        while self._debt >= dt and steps < MAX_STEPS_PER_FRAME and self.clock() - began < STEP_BUDGET:
            start = self.clock()
            try:
                self._settle_graspers()
                self.probe.before_step()
                if self.playback is not None:
                    self.playback.before_step(self.solver, dt)
                self.solver.step(dt)
            except TissuesimError as error:  # a blow-up, a mass-spring surface turned inside out, a scripted tool
                # refused: say so, restart
                if self.playback is not None:
                    self.playback.take_over()
                self.notice = str(error)
                self.pin.release()
                self.held.forget()
                self.grasper.release_all()
                self.probe.adopt(None)
                self.solver.reset()
                self.force = np.zeros(3)
                self._debt = 0.0
                break
            took = self.clock() - start
            self._step_seconds = took if self._step_seconds == 0.0 else (
                (1.0 - SMOOTHING) * self._step_seconds + SMOOTHING * took)
            self._debt -= dt
            steps += 1
        dropped = self._debt - self._debt % dt if self._debt >= dt else 0.0  # never owe more than one step:
        self._debt -= dropped  # a slow frame loses simulated time instead of spiralling behind
        return FrameStats(steps, self._step_seconds, self._step_seconds > dt, dropped)

    @staticmethod
    def _frame_time(elapsed) -> float:
        """``elapsed`` [s] as a float, or SolverError unless finite and at least 0."""
        try:
            if isinstance(elapsed, (bool, np.bool_, str, bytes)):  # True would run a whole frame of steps
                raise TypeError
            seconds = float(elapsed)
        except (TypeError, ValueError):
            raise SolverError(f"a frame's wall time must be a number of seconds, got {elapsed!r}") from None
        if not np.isfinite(seconds) or seconds < 0.0:
            raise SolverError(f"a frame's wall time must be finite and at least 0 s, got {seconds!r}; pass the "
                              "seconds since the last frame of a monotonic clock")
        return seconds

    # ---------------------------------------------------------------------------------------------- internals
    def _settle_graspers(self) -> None:
        """The held patches carried onto their jaws; a carry the tissue cannot follow leaves those jaws where they
        were, changes nothing, and says why in :attr:`notice` (the body is fine: no restart)."""
        try:
            self.grasper.before_step()
        except TissuesimError as error:
            self.notice = f"the grasper's move was refused: {error}"

    def _lifted(self, point: np.ndarray, direction) -> np.ndarray:
        """``point`` moved back along the camera ray by BLADE_LIFT × the blade depth."""
        return point - BLADE_LIFT * self.scalpel.depth * unit_ray(direction)
