"""The simulator's tools beside the live pin-head: pin-heads left holding (a second hand) and the brush that paints
the fixed region. Both are headless, driven by :class:`~tissuesim.viewer.controller.Controller`.

* :class:`HeldPins`: a pin-head released with the hold modifier (Shift) keeps its load, clamped at the cursor
  where it was let go, while the user grabs again or cuts beside it; each holds its own load on the solver
  (:class:`~tissuesim.solvers.load_set.ToolLoad`), so any number act together;
* :class:`SupportBrush`: the vertices within a brush radius of the pointer, gathered over a stroke, become the
  fixed region when the stroke ends (a new solver over the same mesh with ``fixed=`` those vertices).
"""

from __future__ import annotations

import numpy as np

from ..errors import SolverError
from ..interaction import PinHead, checked_point
from ..solvers.checks import positive_number

#: The support brush's default radius, in mean rest edge lengths of M_S.
BRUSH_EDGES = 2.0


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

    def hold(self, pin: PinHead, cursor) -> None:
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

    def moved_to(self, solver, *, stiffness: float, radius: float | None) -> list[PinHead]:
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
    """

    def __init__(self, surface, *, radius: float | None = None):
        if radius is None:
            edges = surface.vertices[surface.edges]
            radius = BRUSH_EDGES * float(np.linalg.norm(edges[:, 0] - edges[:, 1], axis=1).mean())
        self.radius = positive_number("brush radius", radius, "m")
        self.painted = np.zeros(0, dtype=np.int32)

    @property
    def painting(self) -> bool:
        return self.painted.size > 0

    def paint(self, point, positions: np.ndarray) -> None:
        """Add the vertices within the brush radius of ``point`` ``(3,)`` [m], at ``positions`` ``(n, 3)`` [m]
        (the current ones)."""
        distance = np.linalg.norm(positions - checked_point(point), axis=1)
        touched = np.flatnonzero(distance <= self.radius).astype(np.int32)
        self.painted = np.union1d(self.painted, touched).astype(np.int32)

    def finish(self) -> np.ndarray:
        """End the stroke: returns its vertices ``(k,) int32`` and forgets them."""
        painted, self.painted = self.painted, np.zeros(0, dtype=np.int32)
        return painted
