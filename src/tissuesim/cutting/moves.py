"""Vertices moved onto the cut before it is made, so a straight stroke leaves a straight wound (§7 is silent).

Snapping (:mod:`.sweep`) puts an edge point within σ of a vertex onto that vertex, so the cut wandered up to σ of
an edge off the blade's trace. Instead, a vertex v within :data:`MOVE_REACH` of an edge point p on one of its edges
(v, w), or of where the trace leaves the triangle of the move's front tip, is moved onto the cut: to p,
at rest, now and in velocity by the same weights, ``(1 − t) x_v + t x_w`` (§7's barycentric rule, Fig 8: a new
vertex is placed the same way). The cut then goes through v exactly. Rest data follow the rest positions (rest
lengths, angles, areas and masses of v's triangles are made again by the solvers' cut carriers, which see v's
triangles among the changed rows).

A vertex is moved only when

* the caller lets it (``movable``: not fixed, not held, not under a load),
* it lies inside the uncut surface: not on a border or an earlier cut, no copy, no end of a cut's closed tip,
* no triangle of its fan falls below :data:`MOVE_QUALITY` or turns over, at rest or now, and the move stays
  within :data:`MOVE_TILT` of every fan triangle's plane at rest (the body keeps its shape).

Otherwise the point snaps as before. Moves are found nearest first; a vertex's move counts where its neighbours
moved already, so a row of vertices along the cut all go onto it. The work is local: the candidate triangles and
the fans of the vertices near the cut.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..numba_cache import kernel_view
from .snapping import EXACT_MIN, _quality3, along_cut, exit_point

if TYPE_CHECKING:
    from .fans import VertexFans
    from .sweep import Crossing, Sweep

#: A vertex moves onto an edge point at most this fraction of its edge away: beyond the snap fraction too, so the
#: lips are the body's own vertices with their fans, not edge points held by a single edge off the lip (a strip
#: that thin lets a prestrained lip swing over, see :mod:`tissuesim.layer.prestress`).
MOVE_REACH = 0.35
#: A vertex is not moved if a triangle of its fan would fall below this quality (4√3 A / Σ l²) at rest or now.
MOVE_QUALITY = 0.15
#: Nor if its move leaves the plane of a triangle of its fan by more than this angle [rad] at rest: on a fold or a
#: crease (the cube's rim) a move would change the body's shape, where on a smooth surface it stays on it to second
#: order (a 1.4k-vertex sphere's fans bend by about 7°).
MOVE_TILT = np.radians(25.0)


@dataclass(frozen=True)
class VertexMoves:
    """Vertices moved onto the cut: ``vertices (k,) int64`` each to ``(1 − t) x_v + t x_w`` with ``toward (k,)
    int64`` w and ``t (k,) float64`` (of the arrays before the moves)."""

    vertices: np.ndarray
    toward: np.ndarray
    t: np.ndarray

    def __len__(self) -> int:
        return len(self.vertices)

    def values(self, array: np.ndarray) -> np.ndarray:
        """``(k, ...)`` the moved rows of per-vertex ``array`` ``(n, ...)`` (read before the moves)."""
        t = self.t.reshape((-1,) + (1,) * (np.ndim(array) - 1))
        return (1.0 - t) * array[self.vertices] + t * array[self.toward]


NO_MOVES = VertexMoves(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0))


def writable_rows(array: np.ndarray) -> np.ndarray:
    """``array`` itself, or the same rows of the buffer it views when it is a read-only view (a SurfaceMesh
    freezes the views it holds; the buffers under them stay writeable)."""
    owner = array
    while not owner.flags.writeable and owner.base is not None:
        owner = owner.base
    return owner[: len(array)] if owner is not array else array


def plan_moves(rest: np.ndarray, positions: np.ndarray, triangles: np.ndarray, found: list[Crossing],
               fans: VertexFans, *, snap: float, closed: ArrayLike = (),
               movable: Callable[[np.ndarray], ArrayLike] | None = None, sweep: Sweep | None = None) -> VertexMoves:
    """The vertices to move onto the cut of the crossings ``found`` (:func:`~.sweep.crossings`, at ``positions``).

    Args:
        rest, positions: ``(n, 3) float64`` [m]. triangles: ``(m, 3) int``. fans: their :class:`~.fans.VertexFans`.
        snap: σ: an edge point closer than σ × its edge to a vertex moves that vertex.
        closed: ``(p, 2)`` cut edges still shared by two triangles (their ends are on a cut).
        movable: ``f(vertices (k,) int64) -> (k,) bool``, whether the caller lets each vertex move (None: all).
        sweep: the move's :class:`~.sweep.Sweep`: which end of a crossing is its front (None: neither).
    """
    wanted = _nearby_crossings(rest, positions, triangles, found, max(snap, MOVE_REACH), sweep)
    if not wanted:
        return NO_MOVES
    vertices = np.array(sorted(wanted), dtype=np.int64)
    allowed = np.ones(len(vertices), dtype=bool) if movable is None else np.asarray(movable(vertices), dtype=bool)
    on_cut = set(np.asarray(closed, dtype=np.int64).ravel().tolist())
    moved: dict[int, tuple[int, float]] = {}
    where = {"rest": {}, "now": {}}
    for v in sorted(vertices[allowed].tolist(), key=lambda x: min(wanted[x])[0]):
        if v in on_cut:
            continue
        fan = [triangles[r].tolist() for r in fans.fan(v, triangles)]
        if not _interior(v, fan, fans):
            continue
        for _, w, t in sorted(wanted[v]):         # the nearest edge point whose move keeps the fan sound
            if w in moved:
                continue
            targets = {name: (1.0 - t) * a[v] + t * a[w] for name, a in (("rest", rest), ("now", positions))}
            if all(_fan_holds(v, fan, a, where[name], targets[name]) for name, a in (("rest", rest),
                                                                                    ("now", positions))):
                moved[v] = (w, t)
                for name in where:
                    where[name][v] = targets[name]
                break
    if not moved:
        return NO_MOVES
    order = sorted(moved)
    return VertexMoves(np.array(order, dtype=np.int64), np.array([moved[v][0] for v in order], dtype=np.int64),
                       np.array([moved[v][1] for v in order]))


def front_end(ends: np.ndarray, corners: ArrayLike, positions: np.ndarray, sweep: Sweep) -> int:
    """Which of a crossing's barycentric ``ends`` (2, 3) in the triangle ``corners`` lies farther along the move
    (at ``positions``): the tool's side, where the cut goes on."""
    points = ends @ positions[np.asarray(corners)]
    return int((points[1] - points[0]) @ sweep.u > 0.0)


def _nearby_crossings(rest, positions, triangles, found, snap, sweep) -> dict:
    """``{v: [(distance [m], w, t), ...]}``: for each vertex an edge point lies within ``snap`` of (on its edge
    (v, w), at fraction t from v), those edge points and their distances at rest (the crossings are at
    ``positions``); where the front tip of a crossing (the tool's side of the ``sweep``) lies inside its triangle,
    the point where the trace leaves that triangle counts too."""
    wanted: dict[int, list] = {}
    for crossing in found:
        corners = triangles[crossing.triangle]
        # a tip that snaps (a weight below EXACT_MIN) stays within that of the trace: where it would go along
        # the trace instead counts too
        ends = along_cut(crossing.ends, [e for e in range(2) if crossing.ends[e].min() < EXACT_MIN])
        # a tip inside the triangle: where the trace goes on (the next move) may pass near a corner too, which
        # moved now keeps the tip off a triangle whose corners would all come to lie on the cut
        front = None if sweep is None else front_end(ends, corners, positions, sweep)
        ahead = [exit_point(ends[1 - front], ends[front])[0]] if front is not None and np.count_nonzero(
            ends[front] > 0.0) == 3 else []
        for w in list(ends) + ahead:
            on = np.flatnonzero(w > 0.0)
            if on.size != 2:
                continue            # a vertex (on the cut already) or a facet point
            i, j = on
            near, far = (i, j) if w[i] >= w[j] else (j, i)
            t = float(w[far])
            if not 0.0 < t < snap:
                continue
            v, toward = int(corners[near]), int(corners[far])
            entry = (t * float(np.linalg.norm(rest[toward] - rest[v])), toward, t)
            if entry not in wanted.setdefault(v, []):
                wanted[v].append(entry)
    return wanted


def _interior(v: int, fan: list, fans) -> bool:
    """Whether v lies inside the uncut surface: no copy, and each edge of its fan held by two of its triangles."""
    if fans.twins(v) or not fan:
        return False
    count: dict[int, int] = {}
    for row in fan:
        for x in row:
            if x != v:
                count[x] = count.get(x, 0) + 1
    return all(c == 2 for c in count.values())


def _fan_holds(v: int, fan: list, where: np.ndarray, moved: dict, target: np.ndarray) -> bool:
    """Whether every triangle of v's ``fan`` keeps quality ≥ :data:`MOVE_QUALITY` and its orientation with v at
    ``target`` (and the vertices ``moved`` already at theirs), and the move stays within :data:`MOVE_TILT` of each
    triangle's plane."""
    step = target - where[v]
    step_length = float(np.linalg.norm(step))
    for row in fan:
        before = [where[x] for x in row]
        after = [target if x == v else moved.get(x, where[x]) for x in row]
        if _quality3(*map(kernel_view, after)) < MOVE_QUALITY:
            return False
        normal_before = np.cross(before[1] - before[0], before[2] - before[0])
        normal_after = np.cross(after[1] - after[0], after[2] - after[0])
        if float(normal_before @ normal_after) <= 0.0:
            return False
        if abs(float(normal_before @ step)) > np.sin(MOVE_TILT) * step_length * np.linalg.norm(normal_before):
            return False
    return True
