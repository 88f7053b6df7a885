"""Cutting every frame: the surface's arrays in capacity buffers, edited in place, so a move costs O(k), not O(n).

A cut appends a few vertices and triangles and rewrites a few triangle rows. Per-vertex and per-triangle arrays are
therefore kept in buffers with spare rows that grow geometrically (:class:`Spare`); the live array is a prefix view
(O(1) to make), and a move writes only its new and changed rows.

What sharing means for a holder of the arrays or meshes from before a cut: old vertices keep their indices and
their rows (rest positions never change; current positions go on being written by the solver), so an old view of
the positions still shows the first n vertices live. Triangle rows that the cut rewrote change under an old
:class:`~tissuesim.mesh.surface.SurfaceMesh` too, and may name vertices past its end: **a mesh from before a cut is
not valid after it**; copy its arrays (``np.array(mesh.triangles)``) before cutting to keep it. When a buffer runs
out of rows it is reallocated, and from then on older views no longer follow. Nothing in the library keeps a mesh
across a cut: the solver swaps ``solver.hybrid`` for the cut one.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
from numpy.typing import ArrayLike

from ..mesh.coincident import coincident_pairs
from .core import plan_cut
from .fans import VertexFans
from .result import CutPlan, CutResult
from .sweep import Sweep, candidate_triangles, check_snap

#: Capacity growth factor of a buffer that runs out of rows, and the spare rows a buffer starts with (a fraction of
#: its length, at least :data:`MIN_SPARE`).
GROWTH = 1.5
SPARE = 0.25
MIN_SPARE = 256


class Spare:
    """Named capacity buffers. :meth:`extend` appends rows to an array that is a view it returned before (in place,
    O(rows) amortised); any other array (the first call, or one its owner replaced) is adopted by one copy."""

    def __init__(self):
        self._full: dict[str, np.ndarray] = {}
        self._view: dict[str, np.ndarray] = {}
        self._rewritten: list[tuple] = []       # (array, rows, their values before) of each rewrite, in order

    def extend(self, name: str, current: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``current`` ``(n, ...)`` followed by ``rows`` ``(k, ...)``: a view of length n + k of buffer ``name``."""
        n, k = len(current), len(rows)
        full = self._full.get(name)
        if full is None or current is not self._view.get(name):
            full = self._allocate(current, n + k)
        elif n + k > len(full):
            full = self._allocate(full[:n], n + k)
        full[n:n + k] = rows
        view = full[: n + k]
        self._full[name], self._view[name] = full, view
        return view

    def adopt(self, name: str, current: np.ndarray) -> np.ndarray:
        """``current`` as a view of buffer ``name`` (no rows added)."""
        return self.extend(name, current, np.zeros((0,) + np.shape(current)[1:], dtype=np.asarray(current).dtype))

    def rewrite(self, array: np.ndarray, rows: np.ndarray, values: np.ndarray) -> None:
        """Write ``values`` into ``rows`` of ``array`` (a view of a buffer, or any array), keeping what was there
        so that :meth:`restore` puts it back (rows of old vertices a cut changes in place: the moved vertices)."""
        if len(rows) == 0:
            return
        from .moves import writable_rows

        target = writable_rows(array)
        self._rewritten.append((target, np.array(rows), np.array(target[rows])))
        target[rows] = values

    def mark(self) -> tuple:
        """Which views are current, so :meth:`restore` can take back the extends and rewrites since (O(buffers)).
        Only the latest mark can be restored: the rewrites before it are forgotten (their values are not kept)."""
        self._rewritten.clear()
        return dict(self._full), dict(self._view), 0

    def restore(self, mark: tuple) -> None:
        """The buffers as at ``mark``: rows appended since are spare again (their views' rows were never written),
        rows rewritten since have their values back."""
        self._full, self._view = dict(mark[0]), dict(mark[1])
        while len(self._rewritten) > mark[2]:
            target, rows, before = self._rewritten.pop()
            target[rows] = before

    @staticmethod
    def _allocate(current, length):
        current = np.asarray(current)
        capacity = max(int(GROWTH * length), length + MIN_SPARE, int((1.0 + SPARE) * length))
        full = np.empty((capacity,) + current.shape[1:], dtype=current.dtype)
        full[: len(current)] = current
        return full


class CutSurface:
    """M_S's rest positions, positions, velocities and triangles in capacity buffers, cut in place.

    Args:
        rest, positions, velocities: ``(n, 3) float64`` [m], [m], [m/s] (copied once into the buffers).
        triangles: ``(m, 3) int`` triangles.

    A cut is planned (:meth:`plan`, nothing written: a caller may still refuse it) and then applied (:meth:`apply`).
    The sweep's candidate triangles are found by walking the fans outward from seed vertices (where the cut is),
    within the sweep's bounding box (:meth:`VertexFans.near`); only when that cuts nothing is every triangle tested
    (one Numba pass, ~1 ms at 100k triangles).
    A cut therefore follows the sheet of surface it started in: a second sheet that the blade might reach without
    any triangle joining it to the first (a thin fold) is not cut in that move.
    """

    def __init__(self, rest: ArrayLike, positions: ArrayLike, velocities: ArrayLike, triangles: ArrayLike):
        self.spare = Spare()
        self.rest = self.spare.adopt("rest", np.asarray(rest, dtype=np.float64))
        self.positions = self.spare.adopt("positions", np.asarray(positions, dtype=np.float64))
        self.velocities = self.spare.adopt("velocities", np.asarray(velocities, dtype=np.float64))
        self.triangles = self.spare.adopt("triangles", np.asarray(triangles, dtype=np.int32))
        self.fans = VertexFans(self.triangles, len(self.rest))
        # the duplicates of earlier cuts (this surface may have been cut before these buffers were made): the
        # vertices that share a rest position, so the walk crosses their wounds too
        self.fans.record([], np.zeros((0, 3), dtype=np.int64), copies=coincident_pairs(self.rest)[:, ::-1].tolist())

    def sync(self, positions: np.ndarray, velocities: np.ndarray) -> None:
        """Use the solver's current ``positions`` and ``velocities`` (adopted by a copy if they are not ours)."""
        self.positions = self.spare.adopt("positions", positions)
        self.velocities = self.spare.adopt("velocities", velocities)

    def plan(self, sweep: Sweep, *, snap: float, closed: ArrayLike = (), seeds: Iterable[int] = (),
             movable: Callable[[np.ndarray], ArrayLike] | None = None) -> CutPlan | None:
        """The cut of ``sweep`` (see :func:`~tissuesim.cutting.core.plan_cut`) among the triangles found by a walk
        from the vertices ``seeds``; if that cuts nothing, among every triangle the sweep's box meets. ``movable``:
        ``f(vertices (k,) int64) -> (k,) bool``, the vertices that may be moved onto the cut (None: any inside the
        surface; see :mod:`.moves`)."""
        snap = check_snap(snap)
        corners = sweep.corners
        pad = 1e-9 * (np.ptp(corners, axis=0).max() + 1e-300)
        rows = [r for v in seeds for r in self.fans.candidates(int(v))]
        walked = self.fans.near(self.triangles, self.positions, corners.min(axis=0) - pad,
                                corners.max(axis=0) + pad, rows)
        plan = None
        if walked.size:
            plan = plan_cut(self.rest, self.positions, self.triangles, sweep, snap=snap, closed=closed,
                            fans=self.fans, near=walked, movable=movable)
        if plan is None:
            plan = plan_cut(self.rest, self.positions, self.triangles, sweep, snap=snap, closed=closed,
                            fans=self.fans, near=candidate_triangles(self.positions, self.triangles, sweep),
                            movable=movable)
        return plan

    def mark(self, plan: CutPlan) -> tuple:
        """What :meth:`apply` of ``plan`` changes in place, to :meth:`restore` it: the views and the fans of the
        rows it rewrites (the buffers themselves are marked by :meth:`Spare.mark`)."""
        return (self.rest, self.positions, self.velocities, self.triangles,
                self.fans.mark(plan.vertices(), plan.old_count))

    def restore(self, mark: tuple, plan: CutPlan) -> None:
        """The surface as before :meth:`apply` of ``plan`` (the rows it rewrote get their content back)."""
        self.rest, self.positions, self.velocities, self.triangles, fans = mark
        old = plan.changed[plan.changed < len(self.triangles)]
        # through the buffer: a view a SurfaceMesh holds is frozen
        self.triangles.base[old] = plan.replaced
        self.fans.restore(fans)

    def apply(self, plan: CutPlan, sweep: Sweep) -> CutResult:
        """Write ``plan`` into the buffers; the result's arrays are views of them. The moved vertices' rows are
        rewritten first (:meth:`Spare.rewrite`: a move taken back puts them back), so new points interpolate them
        where they now are."""
        spare, n, moves = self.spare, plan.old_count, plan.moves
        moved_from = np.array(self.rest[moves.vertices])
        for array in (self.rest, self.positions, self.velocities):
            spare.rewrite(array, moves.vertices, moves.values(array))
        self.rest = spare.extend("rest", self.rest, plan.interpolate(self.rest))
        self.positions = spare.extend("positions", self.positions, plan.interpolate(self.positions))
        self.velocities = spare.extend("velocities", self.velocities, plan.interpolate(self.velocities))
        patch = plan.patch
        added = np.array(patch.added, dtype=np.int32).reshape(-1, 3)
        self.triangles = spare.extend("triangles", self.triangles, added)
        for r, content in patch.edited.items():
            self.triangles[r] = content
        copies = [(n + i, int(c)) for i, c in enumerate(plan.new_copy_of.tolist()) if c >= 0]
        self.fans.record(plan.changed, self.triangles[plan.changed], copies)
        return plan.result(self.rest, self.positions, self.velocities, self.triangles, sweep, moved_from=moved_from)
