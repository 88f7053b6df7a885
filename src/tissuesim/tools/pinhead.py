"""The pin-head of §8.2: grab a surface node, drag to load it with f = k (x − x0) (eq 24), release.

Headless: it needs only a solver (any method) and cursor positions, so a viewer, a haptic device or a script can
drive it the same way.

    pin = PinHead(solver, stiffness=20.0)     # N/m
    node = pin.grab(cursor)                   # snaps to the nearest M_S node (current positions)
    pin.drag(cursor + [0, 0, 0.01])           # 0.2 N upward on that node
    solver.step()
    pin.release()

Choices where the paper is silent: x0 is the cursor position at the moment of the grab (as §8.2 says), not the
node's position, so grabbing never applies a force by itself; the snap radius defaults to
:data:`SNAP_RADIUS_EDGES` mean M_S edge lengths, and a point farther than that from every node is refused. A node
that a load would not move (a fixed node, or one whose contact patch reaches the fixed region) is passed over for
the nearest one that it would, within the snap radius, and :attr:`PinHead.notice` says so.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SolverError
from ..solvers.checks import checked_point, positive_number
from ..solvers.load_set import ToolLoad
from .base import Tool

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..solvers.base import Solver

#: Default snap radius in mean rest edge lengths of M_S.
SNAP_RADIUS_EDGES = 3.0


class PinHead(Tool):
    """Turns cursor motion into a nodal load on a solver (eq 24).

    Args:
        solver: any :class:`~tissuesim.solvers.base.Solver`.
        stiffness: k of eq 24 [N/m], positive.
        snap_radius: largest distance [m] from the grab point to the node it snaps to; default
            ``SNAP_RADIUS_EDGES`` × the mean rest edge length of M_S.
        radius: the tip's contact radius R [m]: the force is spread, area-weighted, over the M_S nodes within R of
            the grabbed node (:meth:`Solver.add_load`: its own load, beside any other); None (default) loads the
            grabbed node alone.

    Attributes:
        node: the grabbed M_S vertex index, or None.
        anchor: ``(3,) float64`` x0 of eq 24 [m] (cursor at grab time), or None.
        notice: a sentence for the user when the last :meth:`grab` passed over the nearest node (it was fixed, or
            its tip reached the fixed region) and holds a farther one; "" otherwise.
    """

    def __init__(self, solver: Solver, *, stiffness: float, snap_radius: float | None = None,
                 radius: float | None = None):
        for needed in ("positions", "add_load", "move_load", "remove_load"):
            if not hasattr(solver, needed):
                raise SolverError(f"PinHead needs a solver (from tissuesim.make_solver), got {type(solver).__name__}")
        self.solver = solver
        self.stiffness = positive_number("pin-head stiffness", stiffness, "N/m")
        if snap_radius is None:
            surface = solver.hybrid.surface
            edges = surface.edges
            lengths = np.linalg.norm(surface.vertices[edges[:, 0]] - surface.vertices[edges[:, 1]], axis=1)
            snap_radius = SNAP_RADIUS_EDGES * float(lengths.mean())
        self.snap_radius = positive_number("snap radius", snap_radius, "m")
        self.radius = None if radius is None else positive_number("contact radius", radius, "m")
        self.node: int | None = None
        self.anchor: np.ndarray | None = None
        self.notice = ""
        self._load = ToolLoad(solver)     # its own load: other loads on the solver act on beside it

    kind = "pin-head"

    @property
    def grabbed(self) -> bool:
        return self.node is not None

    # the Tool protocol: a press grabs, a move drags
    def press(self, point: ArrayLike) -> int:
        """:meth:`grab` at ``point`` [m], the force zero until the cursor moves; returns the node held."""
        return self.grab(point)

    def move(self, point: ArrayLike) -> np.ndarray:
        """:meth:`drag` to ``point`` [m]; returns the force [N]."""
        return self.drag(point)

    @property
    def engaged(self) -> bool:
        return self.grabbed

    @property
    def force_on_tissue(self) -> np.ndarray | None:
        """The force of the last drag [N] (eq 24), on the grabbed node or its patch; None when none is held."""
        return None if self.node is None else self._load.force

    def grab(self, point: ArrayLike) -> int:
        """Snap to the M_S node nearest ``point`` ``(3,)`` [m] at the current positions that a load would move;
        returns its index.

        A fixed node, or with a contact ``radius`` a node whose patch reaches the fixed region, is passed over for
        the nearest node within the snap radius that a load moves, and :attr:`notice` says so. Raises SolverError
        (holding nothing new) when no node lies within the snap radius, or none there can carry the load.
        """
        point = checked_point(point)
        distance = np.linalg.norm(self.solver.positions - point, axis=1)
        nearest = int(np.argmin(distance))
        if distance[nearest] > self.snap_radius:
            raise SolverError(
                f"nothing to grab: the nearest surface node ({nearest}) is {distance[nearest]:.4g} m from the point, "
                f"farther than the snap radius {self.snap_radius:.4g} m; move the point onto the surface or pass "
                "a larger snap_radius"
            )
        node = self._nearest_movable(distance, nearest)
        self._load.withdraw()
        self.node, self.anchor = node, point.copy()  # the caller's array (or a live node row) may change later
        self.notice = "" if node == nearest else (
            f"node {nearest}, the nearest, {self._why_not(nearest)}; holding node {node} instead, the nearest that "
            f"a load moves ({1e3 * distance[node]:.3g} mm from the point)")
        return node

    def _nearest_movable(self, distance: np.ndarray, nearest: int) -> int:
        """The node within the snap radius, nearest first by ``distance`` ``(n,)`` [m], whose load reaches no fixed
        node; a SolverError naming ``nearest`` when there is none."""
        within = np.flatnonzero(distance <= self.snap_radius)
        for node in within[np.argsort(distance[within], kind="stable")]:
            if not self.solver.support_reached(int(node), self.radius).size:
                return int(node)
        raise SolverError(
            f"nothing to grab that a load would move: every surface node within the snap radius "
            f"{self.snap_radius:.4g} m of the point is in or next to the fixed region (the nearest, node {nearest}, "
            f"{self._why_not(nearest)}); grab farther from the support"
            + ("" if self.radius is None else " or use a smaller contact radius")
        )

    def _why_not(self, node: int) -> str:
        """Why a load at ``node`` would not move it, as a clause."""
        if node in self.solver.support_reached(node, None):
            return "is fixed"
        return f"has a tip of radius {self.radius:g} m that reaches the fixed region"

    def force(self, point: ArrayLike) -> np.ndarray:
        """``(3,) float64`` eq 24's f = k (x − x0) [N] for cursor ``point`` x [m]."""
        if self.node is None:
            raise SolverError("the pin-head holds no node; call grab(point) first")
        return self.stiffness * (checked_point(point) - self.anchor)

    def drag(self, point: ArrayLike) -> np.ndarray:
        """Move the cursor to ``point`` [m]: the grabbed node gets f = k (x − x0) (eq 24); returns f [N]."""
        force = self.force(point)
        self._load.apply(self.node, force, radius=self.radius)
        return force

    def release(self) -> None:
        """Withdraw the force; the pin-head follows the cursor again (no node held)."""
        self._load.withdraw()
        self.node, self.anchor = None, None
