"""What one cut changes: :class:`CutPlan` before any array is written, :class:`CutResult` once it is.

Both describe a new vertex by its parents (old vertices) and barycentric weights, so any per-vertex value carries
over as the same mix of its parents' (§7, Fig 8).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .moves import NO_MOVES, VertexMoves, writable_rows
from .row_patch import RowPatch

if TYPE_CHECKING:
    from .sweep import Sweep


@dataclass(frozen=True, eq=False)
class CutResult:
    """A cut surface and how it relates to the one before.

    Attributes:
        rest: ``(n', 3) float64`` rest positions [m]; the first n rows are the old ones.
        positions: ``(n', 3) float64`` current positions [m].
        velocities: ``(n', 3) float64`` current velocities [m/s].
        triangles: ``(m', 3) int32`` triangles; the first m rows are the old rows (rewritten where split or
            where a corner became a copy).
        old_count: n, the vertex count before the cut.
        parents: ``(n' − n, 3) int64`` old vertices each new vertex n + i interpolates (row i).
        weights: ``(n' − n, 3) float64`` their barycentric weights (sum 1).
        new_copy_of: ``(n' − n,) int64`` for each new vertex n + i, the vertex (new numbering) it duplicates, −1 for
            an inserted point (:attr:`copy_of` is the same over all vertices).
        new_origin: ``(m' − m,) int64`` the old triangle each appended row lies in (:attr:`triangle_origin` is the
            same over all rows).
        changed: ``(k,) int64`` rows of ``triangles`` that are new or rewritten.
        replaced: ``(r, 3) int64`` the content before the cut of the rewritten old rows ``changed[changed < m]``.
        cut_edges: ``(c, 2) int64`` the edges cut by this move (vertex pairs, before duplication).
        closed: ``(p, 2) int64`` cut edges still shared by two triangles (a cut's tips), to pass to the next cut.
        split_count: old triangles split.
        end_vertex: the cut point farthest along the sweep (where the cut stopped) on the sheet nearest the tool
            tip, −1 if none; a progressive cut starts its next sweep there so the wound stays one path.
        moves: the old vertices moved onto the cut (:mod:`.moves`; :attr:`moved`): their rows of ``rest``,
            ``positions`` and ``velocities`` changed, and their triangles are among ``changed``; a carrier moves
            its own per-vertex values the same way (``moves.values(array)``, read before it writes).
        moved_from: ``(k, 3) float64`` their rest positions before the cut [m].
    """

    rest: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    triangles: np.ndarray
    old_count: int
    parents: np.ndarray
    weights: np.ndarray
    new_copy_of: np.ndarray
    new_origin: np.ndarray
    changed: np.ndarray
    replaced: np.ndarray
    cut_edges: np.ndarray
    closed: np.ndarray
    split_count: int
    end_vertex: int = -1
    moves: VertexMoves = NO_MOVES
    moved_from: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def moved(self) -> np.ndarray:
        """``(k,) int64`` the old vertices moved onto the cut."""
        return self.moves.vertices

    @contextmanager
    def rest_before_moves(self) -> Iterator[None]:
        """Within it, ``rest`` holds the moved vertices' rest positions from before the cut (for what a carrier
        takes away: the old triangles' areas and stiffness); O(moved)."""
        if not len(self.moved):
            yield
            return
        rest = writable_rows(self.rest)
        after = np.array(rest[self.moved])
        rest[self.moved] = self.moved_from
        try:
            yield
        finally:
            rest[self.moved] = after

    @property
    def old_triangle_count(self) -> int:
        """m, the triangle count before the cut."""
        return len(self.triangles) - len(self.new_origin)

    @property
    def copy_of(self) -> np.ndarray:
        """``(n',) int64`` the vertex (new numbering) a duplicate copies, −1 for the others (a new array)."""
        return np.concatenate([np.full(self.old_count, -1, dtype=np.int64), self.new_copy_of])

    @property
    def triangle_origin(self) -> np.ndarray:
        """``(m',) int64`` the old triangle each triangle lies in (a new array)."""
        return np.concatenate([np.arange(self.old_triangle_count), self.new_origin])

    def origin_of(self, rows: np.ndarray) -> np.ndarray:
        """``(k,) int64`` the old triangle each of ``rows`` lies in."""
        rows = np.asarray(rows, dtype=np.int64)
        m = self.old_triangle_count
        origin = rows.copy()
        origin[rows >= m] = self.new_origin[rows[rows >= m] - m]
        return origin

    def before(self, rows: np.ndarray) -> np.ndarray:
        """``(k, 3) int64`` the content before the cut of old rows ``rows``."""
        rows = np.asarray(rows, dtype=np.int64)
        content = np.array(self.triangles[rows], dtype=np.int64)
        old = self.changed[self.changed < self.old_triangle_count]
        where = np.searchsorted(old, rows)
        hit = where < old.size
        hit[hit] = old[where[hit]] == rows[hit]
        content[hit] = self.replaced[where[hit]]
        return content

    def interpolate(self, values: np.ndarray) -> np.ndarray:
        """``(n' − n, ...)`` per-vertex ``values`` ``(n, ...)`` at the new vertices (their parents' mix)."""
        return _mix(self.weights, self.parents, values)

    def parents_of(self, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(parents (k, 3) int64, weights (k, 3))`` of any ``vertices`` (an old vertex is its own parent)."""
        vertices = np.asarray(vertices, dtype=np.int64)
        parents = np.repeat(vertices[:, None], 3, axis=1)
        weights = np.zeros((len(vertices), 3))
        weights[:, 0] = 1.0
        new = vertices >= self.old_count
        parents[new] = self.parents[vertices[new] - self.old_count]
        weights[new] = self.weights[vertices[new] - self.old_count]
        return parents, weights


@dataclass
class CutPlan:
    """What one cut changes, before any array is written: new vertices by their parents, and the rows edited on a
    :class:`~tissuesim.cutting.row_patch.RowPatch`. :func:`~.core.cut_surface` and
    :class:`~tissuesim.cutting.buffers.CutSurface` apply it, to new arrays or in place."""

    old_count: int
    parents: np.ndarray             # (v, 3) int64 old vertices of each new vertex
    weights: np.ndarray             # (v, 3) float64
    new_copy_of: np.ndarray         # (v,) int64
    patch: RowPatch
    origin: list                    # old triangle of each appended row
    changed: np.ndarray             # (k,) int64 sorted rows new or rewritten
    replaced: np.ndarray            # (r, 3) int64 content before the cut of changed[changed < m]
    cut_list: list
    still_closed: list
    split_count: int
    segments: dict
    moves: VertexMoves = NO_MOVES

    def interpolate(self, values: np.ndarray) -> np.ndarray:
        """``(v, ...)`` per-vertex ``values`` ``(n, ...)`` at the new vertices (their parents' barycentric mix)."""
        return _mix(self.weights, self.parents, values)

    def vertices(self) -> np.ndarray:
        """``(k,) int64`` every vertex of the rows this plan rewrites or appends, before and after it, ascending."""
        rows = list(self.patch.edited.values()) + self.patch.added
        return np.unique(np.concatenate([self.replaced.ravel(), np.asarray(rows, dtype=np.int64).ravel()]))

    def result(self, rest: np.ndarray, positions: np.ndarray, velocities: np.ndarray, triangles: np.ndarray,
               sweep: Sweep, moved_from: np.ndarray | None = None) -> CutResult:
        """The cut once written (arrays of the new surface; ``moved_from`` ``(k, 3)``: the moved vertices' rest
        positions before it [m])."""
        return CutResult(moves=self.moves,
                         moved_from=np.zeros((0, 3)) if moved_from is None else moved_from,
                         rest=rest, positions=positions, velocities=velocities, triangles=triangles,
                         old_count=self.old_count, parents=self.parents, weights=self.weights,
                         new_copy_of=self.new_copy_of, new_origin=np.array(self.origin, dtype=np.int64),
                         changed=self.changed, replaced=self.replaced,
                         cut_edges=np.array(self.cut_list, dtype=np.int64).reshape(-1, 2),
                         closed=np.array(self.still_closed, dtype=np.int64).reshape(-1, 2),
                         split_count=self.split_count, end_vertex=_farthest(self.segments, positions, sweep))


def _mix(weights, parents, values):
    return np.einsum("ij,ij...->i...", weights, values[parents])


def _farthest(segments, positions, sweep) -> int:
    """The segment end farthest along the move (the tip's side of the cut), on the sheet nearest the tool tip.

    A blade deeper than the body crosses two sheets (the top and the bottom of a slab entered from the side), whose
    fronts lie level along the move to within the snapping. The blade enters the sheet nearest its tip first, so a
    front point shallower by more than a cut segment's length (more than one sheet can slope between two points a
    segment apart) wins: the next move's walk then follows that sheet."""
    pairs = np.array(list(segments.values()), dtype=np.int64).reshape(-1, 2)
    ends = np.unique(pairs.ravel())
    if ends.size == 0:
        return -1
    st = sweep.plane_coordinates(positions[ends])
    along, deep = st[:, 0] * np.linalg.norm(sweep.u), st[:, 1] * np.linalg.norm(sweep.v)     # [m]
    reach = float(np.linalg.norm(positions[pairs[:, 0]] - positions[pairs[:, 1]], axis=1).max())
    best = int(np.argmax(along))
    front = np.flatnonzero((along >= along[best] - reach) & (deep < deep[best] - reach))
    if front.size:
        best = int(front[np.argmin(deep[front])])
    return int(ends[best])
