"""The scalpel of §7/§8.4: press on the surface, move to cut, release. Headless, shaped like the pin-head.

    scalpel = Scalpel(solver, depth=0.01)       # blade 1 cm long [m]
    scalpel.press(point)                        # blade along the inward normal at the press point
    scalpel.move(point + [0.01, 0, 0])          # cuts the sweep between the previous blade and this one
    solver.step()
    scalpel.release()

The cut is progressive: each ``move`` cuts at once, so the wound grows under the tool (the paper cuts at the
release). Each call returns a :class:`~tissuesim.solvers.cut_carry.CutReport`.

Choices where the paper is silent:

* the blade is a segment of ``depth`` [m] from the tool tip along ``direction``, fixed at the press (by default the
  inward normal of the surface there), so each move sweeps a flat parallelogram;
* ``press`` refuses a point farther than ``depth`` from the surface, naming the distance;
* the blade is at most the model's size long (the diagonal of the surface's bounding box when the scalpel is made):
  a longer one reaches through the body to the far side (the fixed bottom of the cube at 1e8 m) and, far longer,
  overflows the sweep's arithmetic; a move farther than :data:`MOVE_REACH` model sizes from the surface's bounding
  box is refused too (a tip parked at 1e300 m would do the same on the next move);
* a move shorter than ``snap`` × the mean edge length is kept for later: its sweep would make only slivers, so the
  tool's last cutting position stays until it has moved far enough; a cut that ends at the edge a move entered by
  (its tip would have snapped beside the trace) goes on from there in the next move, and one that reached past the
  tool waits until the tool has passed it;
* ``snap`` is a fraction of the local edge length (see :mod:`tissuesim.cutting.sweep`).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from ..cutting.core import DEFAULT_SNAP
from ..solvers.cut_carry import CutReport, cut_updater
from ..cutting.sweep import Sweep, check_snap, triangles_in_box
from ..errors import SolverError
from ..solvers.checks import checked_point, numeric_array, positive_number
from .base import Tool

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..solvers.base import Solver

#: Default blade length in mean rest edge lengths of M_S.
DEPTH_EDGES = 2.0
#: Farthest a move may take the tool from the surface's bounding box, in model sizes (bounding-box diagonals): a
#: hand off the tissue stays within a few, a point beyond is a units or input error.
MOVE_REACH = 3.0


class Scalpel(Tool):
    """Cuts a solver's fine surface M_S as a tool moves (§7).

    Args:
        solver: a hybrid, pbd, mass-spring or embedded solver (the fem reference refuses, saying why).
        depth: blade length [m] from the tip into the tissue, at most the model's size; default ``DEPTH_EDGES`` mean
            rest edge lengths (or the model's size, on a mesh of a few long edges).
        snap: snap fraction of the local edge length in [0.15, 1/3) (default
            :data:`tissuesim.cutting.core.DEFAULT_SNAP`; below :data:`tissuesim.cutting.sweep.MIN_SNAP` = 0.15 cut
            points too close to merge make zero-area triangles or slivers, so it is refused).

    Attributes:
        tip: ``(3,) float64`` where the last cut stopped [m], or None when not pressed.
        direction: ``(3,) float64`` unit blade direction, or None.
        size: the model's size [m]: the diagonal of the surface's bounding box when the scalpel was made.
    """

    def __init__(self, solver: Solver, *, depth: float | None = None, snap: float = DEFAULT_SNAP):
        self.solver = solver
        self._updater = cut_updater(solver)
        surface = solver.hybrid.surface
        edges = surface.edges
        self._edge = float(np.linalg.norm(surface.vertices[edges[:, 0]] - surface.vertices[edges[:, 1]],
                                          axis=1).mean())
        self.size = float(np.linalg.norm(np.ptp(solver.positions, axis=0)))
        self.depth = positive_number("blade depth", min(DEPTH_EDGES * self._edge, self.size) if depth is None else depth, "m")
        if self.depth > self.size:
            raise SolverError(f"blade depth {self.depth:.4g} m is longer than the model's size {self.size:.4g} m (the "
                              "diagonal of its bounding box): it would cut through to the far side; pass a depth of "
                              f"at most {self.size:.4g} m")
        self.snap = check_snap(snap)
        self.tip: np.ndarray | None = None
        self.direction: np.ndarray | None = None
        self._anchor = -1       # the vertex where the last move's cut stopped
        self._pressed_on = np.zeros(0, dtype=np.int64)     # corners of the triangle pressed on
        self._pressed_at: np.ndarray | None = None          # the press point [m]

    kind = "scalpel"
    needs = "a cut carrier (the method's cut_carrier)"

    @property
    def pressed(self) -> bool:
        return self.tip is not None

    @property
    def engaged(self) -> bool:
        return self.pressed

    def prepare(self) -> None:
        """Get the solver ready for a cut that is about to come, e.g. when the tool is picked up: what its first
        move needs (the layer's explicit factor) is built in the background from now. :meth:`press` does it too."""
        self._updater.prepare()

    def press(self, point: ArrayLike, direction: ArrayLike | None = None) -> CutReport:
        """Put the tool tip at ``point`` ``(3,)`` [m]; the blade points along ``direction`` ``(3,)``, a vector of
        any finite, non-zero length (default: the inward normal there); SolverError for anything else."""
        start = time.perf_counter()
        point = checked_point(point)
        tri, bary = self._touch(point)
        corners = self.solver.positions[self.solver.hybrid.surface.triangles[tri]]
        if direction is None:
            normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])      # outward: counter-clockwise
            direction = -normal
        self.tip, self.direction = point, _unit(direction)
        self._pressed_at = point
        self._anchor = -1
        self._pressed_on = self.solver.hybrid.surface.triangles[tri].astype(np.int64)
        self._updater.prepare()
        return CutReport(seconds=time.perf_counter() - start)

    def _touch(self, point: np.ndarray) -> tuple[int, np.ndarray]:
        """The triangle (row) and barycentric weights of the surface point closest to ``point``, now: searched among
        the triangles within the blade's reach (a box test), so a press costs O(1) Python work; SolverError with the
        distance when the surface is beyond the blade."""
        from ..mesh.maps import closest_among, closest_on_surface
        from ..mesh.surface import SurfaceMesh

        positions, triangles = self.solver.positions, self.solver.hybrid.surface.triangles
        reach = np.full(3, self.depth)
        rows = triangles_in_box(positions, triangles, point - reach, point + reach)
        tri, bary, distance = (a[0] for a in closest_among(positions, triangles, point, rows))
        if distance > self.depth:
            # only to name the distance: search the whole surface (a copy, as SurfaceMesh freezes its arrays)
            tri_all, bary_all = closest_on_surface(SurfaceMesh(np.array(positions), triangles), point[None])
            distance = float(np.linalg.norm(bary_all[0] @ positions[triangles[tri_all[0]]] - point))
            raise SolverError(f"nothing to cut: the point is {distance:.4g} m from the surface, farther than the "
                              f"blade depth {self.depth:.4g} m; press on the surface or pass a larger depth")
        return int(tri), bary

    def move(self, point: ArrayLike) -> CutReport:
        """Move the tip to ``point`` ``(3,)`` [m], cutting the surface the blade sweeps on the way."""
        if self.tip is None:
            raise SolverError("the scalpel is not pressed; call press(point) first")
        start = time.perf_counter()
        point = self._within_reach(checked_point(point))
        origin = self._start()
        if np.linalg.norm(point - origin) < self.snap * self._edge:
            return CutReport(seconds=time.perf_counter() - start)
        if self._anchor >= 0 and (point - origin) @ (point - self.tip) <= 0.0:
            # the last cut reached past the tool (to the far side of its triangle): cut on once the tool passes it
            self.tip = point
            return CutReport(seconds=time.perf_counter() - start)
        # the sweep's triangles are searched outward from where the cut is (see cutting.buffers.CutSurface)
        seeds = [self._anchor] if self._anchor >= 0 else self._pressed_on
        report, end = self._updater.apply(Sweep.between(origin, point, self.depth * self.direction),
                                          snap=self.snap, seeds=seeds)
        self.tip = point
        if end >= 0:
            self._anchor = end
        return report

    def _within_reach(self, point: np.ndarray) -> np.ndarray:
        """``point`` ``(3,)`` [m], or SolverError naming it when farther than MOVE_REACH model sizes from the
        surface's bounding box now."""
        positions = self.solver.positions
        outside = np.maximum(positions.min(axis=0) - point, 0.0) + np.maximum(point - positions.max(axis=0), 0.0)
        largest = float(np.max(outside))  # scaled before squaring: a point at 1e300 m must not overflow to inf
        distance = 0.0 if largest == 0.0 else largest * float(np.linalg.norm(outside / largest))
        if distance > MOVE_REACH * self.size:
            raise SolverError(f"the scalpel cannot move to {point.tolist()}: it is {distance:.4g} m from the model, "
                              f"farther than {MOVE_REACH:g} × its size {self.size:.4g} m; move the tool near the "
                              "surface (coordinates in metres)")
        return point

    def _start(self) -> np.ndarray:
        """Where this move's sweep starts: the tip, moved across the blade so the blade passes through the vertex
        where the last cut stopped (behind the tip, or past it, see :func:`tissuesim.cutting.snapping.along_cut`),
        so the cut stays one path; the press point while nothing has been cut (a move may end its cut at the edge
        it entered by, which leaves nothing to cut in a first short move)."""
        if self._anchor < 0:
            return self._pressed_at
        anchor = self.solver.positions[self._anchor]
        return anchor - ((anchor - self.tip) @ self.direction) * self.direction

    def release(self) -> CutReport:
        """Lift the tool; the cut stays (its tips stay closed until a later cut goes on from them)."""
        self.tip, self.direction = None, None
        return CutReport()


def _unit(direction) -> np.ndarray:
    """``direction`` ``(3,)`` scaled to unit length: by its largest component first, so neither a huge vector
    (whose squared length overflows) nor a tiny one (whose squared length underflows) loses it; SolverError for
    anything but 3 finite numbers, not all zero."""
    given, direction = direction, numeric_array(direction)   # np.asarray would read ["0", "0", "-1"] as a vector
    if direction is None or direction.shape != (3,) or not np.all(np.isfinite(direction)):
        raise SolverError("the blade direction must be 3 finite numbers (a vector into the tissue, any length), "
                          f"got {given!r}; pass none for the inward normal")
    largest = float(np.max(np.abs(direction)))
    if largest == 0.0:
        raise SolverError("the blade direction must be a non-zero vector, got [0, 0, 0]; pass the direction the "
                          "blade points into the tissue, or none for the inward normal")
    direction = direction / largest
    return direction / np.linalg.norm(direction)
