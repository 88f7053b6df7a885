"""The simulator's tools beside the live pin-head: the grasper, pin-heads left holding (a second hand), the probe and
the brush that paints the fixed region. All are headless, driven by :class:`~tissuesim.viewer.controller.Controller`.

* :class:`GrasperTool`: jaws (:class:`~tissuesim.tools.grasper.Grasper`) that hold the surface vertices within their reach
  of the point pressed and carry them rigidly where the pointer drags the jaws, in the plane facing the camera; each
  step first settles every held patch on its jaws (:meth:`~tissuesim.tools.grasper.Grasper.settle`), so the tissue goes
  where the hand goes and the force is the output. Let go with the hold modifier (Shift), the jaws keep holding, so
  several hold at once;

* :class:`HeldPins`: a pin-head released with the hold modifier (Shift) keeps its load, clamped at the cursor
  where it was let go, while the user grabs again or cuts beside it; each holds its own load on the solver
  (:class:`~tissuesim.solvers.load_set.ToolLoad`), so any number act together;
* :class:`SupportBrush`: the vertices within a brush radius of the pointer, gathered over a stroke, become the
  fixed region when the stroke ends (a new solver over the same mesh with ``fixed=`` those vertices);
* :class:`ProbeTool`: the rigid probe (:class:`~tissuesim.tools.probe.Probe`) pressed where the pointer touches the
  surface, :attr:`ProbeTool.depth` beyond it along the view, and slid in the plane facing the camera. Where it moved,
  the frame solves its contact quasi-statically (:meth:`~tissuesim.tools.probe.Probe.settle`), the tissue being overdamped
  at a hand's speed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SolverError
from ..tools.grasper import Grasper
from ..tools.pinhead import PinHead
from ..tools.probe import Probe
from ..solvers.finite_strain import slow_static_solve
from ..solvers.checks import checked_point, positive_number
from .rays import camera_plane_point, unit_ray

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..mesh.surface import SurfaceMesh
    from ..solvers.base import Solver

#: The support brush's default radius, in mean rest edge lengths of M_S.
BRUSH_EDGES = 2.0
#: A painted ligament's default total stiffness [N/m]: a few times a pin-head's pull, so a held organ sways but stays.
DEFAULT_LIGAMENT = 200.0
#: The grasper's default reach, in mean rest edge lengths of M_S: the jaws take a patch of a few vertices.
GRASP_EDGES = 2.0
#: How far the probe presses beyond the surface it touches, as a fraction of its radius (δ ≪ R: Hertz's range).
PRESS_FRACTION = 0.3


class HeldPins:
    """Pin-heads left holding: each a :class:`PinHead` grabbed at its node and dragged to where it was let go.

    Attributes:
        pins: the held pin-heads, oldest first.
        cursors: ``(h, 3) float64`` where each one was let go [m] (its eq 24 cursor, fixed from then on).
    """

    def __init__(self):
        self.pins: list[PinHead] = []
        self._cursors: list[np.ndarray] = []

    def __len__(self) -> int:
        return len(self.pins)

    @property
    def cursors(self) -> np.ndarray:
        return np.array(self._cursors).reshape(-1, 3)

    @property
    def nodes(self) -> np.ndarray:
        """``(h,) int64`` the held M_S vertices."""
        return np.array([pin.node for pin in self.pins], dtype=np.int64)

    def hold(self, pin: PinHead, cursor: ArrayLike) -> None:
        """Keep ``pin`` (grabbed, its load acting) clamped at ``cursor`` ``(3,)`` [m]."""
        if not pin.grabbed:
            raise SolverError("only a pin-head that holds a node can be left holding; grab first")
        self.pins.append(pin)
        self._cursors.append(checked_point(cursor).copy())

    def release_all(self) -> None:
        """Every held pin-head lets go; its load is withdrawn."""
        for pin in self.pins:
            pin.release()
        self.pins, self._cursors = [], []

    def forget(self) -> None:
        """Drop the held pin-heads without touching their solver (it was replaced or reset)."""
        self.pins, self._cursors = [], []

    def moved_to(self, solver: Solver, *, stiffness: float, radius: float | None) -> list[PinHead]:
        """The held pin-heads rebuilt on ``solver`` (a new solver over the same vertices), each holding its node
        and its load; the live list is untouched, so a refusal here changes nothing (:meth:`adopt` swaps)."""
        moved = []
        for pin, cursor in zip(self.pins, self._cursors):
            again = PinHead(solver, stiffness=stiffness, radius=radius)
            again.node, again.anchor = pin.node, pin.anchor
            again.drag(cursor)
            moved.append(again)
        return moved

    def adopt(self, pins: list[PinHead]) -> None:
        """The pin-heads of :meth:`moved_to` become the held ones."""
        self.pins = pins

    def restiffen(self, *, stiffness: float, radius: float | None) -> None:
        """A new pin-head stiffness [N/m] or contact radius [m] for every held one, their loads re-applied."""
        for pin, cursor in zip(self.pins, self._cursors):
            pin.stiffness, pin.radius = stiffness, radius
            pin.drag(cursor)


class SupportBrush:
    """Paints the fixed region: the M_S vertices within :attr:`radius` of the pointer, gathered over a stroke.

    Args:
        surface: the M_S :class:`~tissuesim.mesh.surface.SurfaceMesh` at rest (it sets the default radius).
        radius: brush radius [m]; default :data:`BRUSH_EDGES` mean rest edge lengths of ``surface``.

    Attributes:
        painted: ``(k,) int32`` sorted vertices painted in the stroke so far (empty before one).
        paints: what a stroke makes: ``"fixed"`` (the fixed region) or ``"ligament"`` (an elastic attachment of
            :attr:`ligament_stiffness` [N/m] to the painted vertices' rest positions).
    """

    def __init__(self, surface: SurfaceMesh, *, radius: float | None = None):
        if radius is None:
            edges = surface.vertices[surface.edges]
            radius = BRUSH_EDGES * float(np.linalg.norm(edges[:, 0] - edges[:, 1], axis=1).mean())
        self.radius = positive_number("brush radius", radius, "m")
        self.painted = np.zeros(0, dtype=np.int32)
        self.paints = "fixed"
        self.ligament_stiffness = DEFAULT_LIGAMENT

    @property
    def painting(self) -> bool:
        return self.painted.size > 0

    def paint(self, point: ArrayLike, positions: np.ndarray) -> None:
        """Add the vertices within the brush radius of ``point`` ``(3,)`` [m], at ``positions`` ``(n, 3)`` [m]
        (the current ones)."""
        distance = np.linalg.norm(positions - checked_point(point), axis=1)
        touched = np.flatnonzero(distance <= self.radius).astype(np.int32)
        self.painted = np.union1d(self.painted, touched).astype(np.int32)

    def finish(self) -> np.ndarray:
        """End the stroke: returns its vertices ``(k,) int32`` and forgets them."""
        painted, self.painted = self.painted, np.zeros(0, dtype=np.int32)
        return painted


class ProbeTool:
    """The simulator's rigid sphere (see the module docstring).

    Args:
        radius: the probe's radius R [m].

    Attributes:
        radius: R [m]; depth: how far it presses beyond the surface point it was put on, along the view [m]
            (default :data:`PRESS_FRACTION` × R).
        probe: the :class:`~tissuesim.tools.probe.Probe` pressing now, or None.
        held: whether it was let go with the hold modifier (it presses on until pressed elsewhere or released).
    """

    def __init__(self, *, radius: float):
        self.radius = positive_number("probe radius", radius, "m")
        self.depth = PRESS_FRACTION * self.radius
        self.probe: Probe | None = None
        self.held = False
        self._settled = False

    @property
    def pressing(self) -> bool:
        return self.probe is not None

    @property
    def force(self) -> np.ndarray:
        """``(3,) float64`` the contact force on the probe [N] (zero when it does not press)."""
        return np.zeros(3) if self.probe is None else self.probe.force

    def press(self, solver: Solver, hit: ArrayLike, ray_direction: ArrayLike) -> None:
        """Put the probe on ``solver``'s surface at ``hit`` ``(3,)`` [m], pressed :attr:`depth` into it along the
        camera ray; refused (SolverError, nothing pressed) where the probe is smaller than the triangles there or
        reaches the support."""
        ray = unit_ray(ray_direction)
        probe = Probe(solver, radius=self.radius)
        probe.move_to(checked_point(hit) + (self.depth - self.radius) * ray)
        self.release()
        self.probe, self._settled = probe, False

    def let_go(self, *, hold: bool) -> None:
        """The button was released: with ``hold`` the probe presses on where it is, else it is withdrawn (a held
        probe stays: the release that ends a mode is no release of it)."""
        if hold and self.probe is not None:
            self.held = True
        elif not self.held:
            self.release()

    def drag(self, ray_origin: ArrayLike, ray_direction: ArrayLike) -> None:
        """Slide the probe to where the camera ray meets the plane through its centre facing the camera."""
        if self.probe is None:
            return
        point = camera_plane_point(ray_origin, ray_direction, self.probe.center)
        if point is not None:
            self.probe.move_to(point)
            self._settled = False

    def before_step(self) -> None:
        """The contact solved where the probe moved (:meth:`~tissuesim.tools.probe.Probe.settle`: a frame's iterations;
        it goes on at the next step if not settled), or on a method whose static solve is slow (a finite-strain
        hybrid: 0.26 s a frame on the liver) one relaxed contact update a frame
        (:meth:`~tissuesim.tools.probe.Probe.update`), the step relaxing the rest. A solver that cannot carry the press
        withdraws the probe and raises."""
        if self.probe is None or self._settled:
            return
        try:
            if slow_static_solve(self.probe.solver):
                self.probe.update()
            else:
                self._settled = self.probe.settle(self.probe.center, self.probe.end)
        except SolverError:
            self.probe = None
            raise

    def release(self) -> None:
        if self.probe is not None:
            self.probe.release()
        self.probe, self.held = None, False

    def moved_to(self, solver: Solver) -> Probe | None:
        """The pressing probe rebuilt on ``solver`` (a new solver over the same vertices), at the same place; the
        live one is untouched (:meth:`adopt` swaps)."""
        if self.probe is None:
            return None
        again = Probe(solver, radius=self.radius)
        again.move_to(self.probe.center, self.probe.end)
        return again

    def adopt(self, probe: Probe | None) -> None:
        self.probe, self._settled = probe, False
        self.held = self.held and probe is not None


class GrasperTool:
    """The simulator's jaws (see the module docstring).

    Args:
        radius: the jaws' reach [m]: a press holds the surface vertices within it of the point pressed.

    Attributes:
        radius: the reach [m] of the next grab.
        grasper: the :class:`~tissuesim.tools.grasper.Grasper` the pointer drags now, or None.
        held: the graspers left holding, oldest first.
    """

    def __init__(self, *, radius: float):
        self.radius = positive_number("grasper reach", radius, "m")
        self.grasper: Grasper | None = None
        self.held: list[Grasper] = []
        self._aims: dict[Grasper, np.ndarray] = {}    # where the pointer put jaws not yet settled there [m]

    @property
    def grasping(self) -> bool:
        return self.grasper is not None

    @property
    def graspers(self) -> list[Grasper]:
        """Every grasper holding: those left holding, then the dragged one."""
        return self.held + ([] if self.grasper is None else [self.grasper])

    @property
    def force(self) -> np.ndarray:
        """``(3,) float64`` the tissue's reaction on the dragged jaws [N] (zero when none drags)."""
        return np.zeros(3) if self.grasper is None else self.grasper.force

    def jaws(self) -> list[tuple[np.ndarray, float]]:
        """``[(position (3,) [m], reach [m])]`` of every grasper holding, where the pointer put it (to draw and
        record)."""
        return [(self._aims.get(grasper, grasper.position), grasper.radius) for grasper in self.graspers]

    def grab(self, solver: Solver, hit: ArrayLike) -> None:
        """Take hold of ``solver``'s surface within :attr:`radius` of ``hit`` ``(3,)`` [m]; refused (SolverError,
        nothing held, nothing changed) where no vertex is in reach, or the patch has a fixed vertex or one that
        other jaws hold."""
        grasper = Grasper(solver, radius=self.radius)
        grasper.grab(hit)
        if self.grasper is not None:        # a press without a release before it: the old jaws let go
            self._drop(self.grasper)
        self.grasper = grasper

    def drag(self, ray_origin: ArrayLike, ray_direction: ArrayLike) -> None:
        """Aim the dragged jaws where the camera ray meets the plane through them facing the camera; the next step
        carries the patch there."""
        if self.grasper is None:
            return
        anchor = self._aims.get(self.grasper, self.grasper.position)
        point = camera_plane_point(ray_origin, ray_direction, anchor)
        if point is not None:
            self._aims[self.grasper] = point

    def let_go(self, *, hold: bool) -> None:
        """The button was released: with ``hold`` the dragged jaws keep holding where they were aimed, else they
        let go."""
        if self.grasper is None:
            return
        if hold:
            self.held.append(self.grasper)
        else:
            self._drop(self.grasper)
        self.grasper = None

    def before_step(self) -> None:
        """Every held patch settled on its jaws, each where the pointer aimed it (a frame's iterations; a patch
        not there yet, or moved by another tool, goes on at the next step). A motion the tissue cannot follow (a
        volume it would invert) is refused: those jaws stay where they were, nothing changes, and SolverError says
        why. (:meth:`~tissuesim.tools.grasper.Grasper.follow`: a finite-strain hybrid gets one relaxed update a frame, its
        static solve taking seconds at 10k vertices.)"""
        for grasper in self.graspers:
            grasper.follow(self._aims.pop(grasper, None))

    def release_all(self) -> None:
        """Every grasper lets go, the dragged one and those left holding; their forces are withdrawn."""
        for grasper in self.graspers:
            self._drop(grasper)
        self.grasper, self.held = None, []

    def moved_to(self, solver: Solver) -> tuple[list[Grasper], Grasper | None]:
        """``(held, dragged)``: every grasper rebuilt on ``solver`` (a new solver over the same vertices, at rest),
        holding its patch and carrying it a frame's worth toward its jaws (the steps go on); the live ones are
        untouched, so a refusal here changes nothing (:meth:`adopt` swaps). Every patch is taken at rest before
        any is carried."""
        moved = {grasper: _regrabbed(grasper, solver) for grasper in self.graspers}
        for grasper, again in moved.items():
            again.settle(self._aims.get(grasper, grasper.position), grasper.rotation)
        return [moved[grasper] for grasper in self.held], moved.get(self.grasper)

    def adopt(self, graspers: tuple[list[Grasper], Grasper | None]) -> None:
        """The graspers of :meth:`moved_to` (or ``([], None)``: none) become the live ones."""
        self.held, self.grasper = graspers
        self._aims = {}

    def _drop(self, grasper: Grasper) -> None:
        grasper.release()
        self._aims.pop(grasper, None)


def _regrabbed(grasper: Grasper, solver) -> Grasper:
    """New jaws on ``solver`` (at rest) holding ``grasper``'s patch, not yet carried.

    They grab where the old jaws were, relative to the patch, at its grab: the patch's grip is the old targets less
    the jaws, turned back. That is exact for a patch grabbed at rest; one grabbed deformed keeps its vertices'
    offsets about their mean, to within its deformation at the grab."""
    grip = (grasper.targets() - grasper.position) @ grasper.rotation        # (k, 3) X_i − p₀ [m]
    again = Grasper(solver, radius=grasper.radius, tolerance=grasper.tolerance)
    again.grab((solver.positions[grasper.held] - grip).mean(axis=0))
    return again

