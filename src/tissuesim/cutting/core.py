"""§7 on arrays: one cut of the fine surface M_S by one sweep of the blade, returning a new surface and maps.

:func:`cut_surface` runs the three steps of §7 on plain arrays and leaves its inputs untouched:

1. the sweep's crossings with the triangles at their current positions (:mod:`.sweep`), snapped, become edge points
   (keyed by their edge, so both triangles of an edge share the point) and facet points (:mod:`.points`);
2. every triangle with a crossing segment or an edge point on a side is split by the case of Fig 7 that fits
   (:mod:`.pieces`), in the plane of its rest triangle; the first piece keeps the triangle's row, the others
   are appended;
3. the vertices along the cut edges are duplicated per side (:mod:`.separate`).

:func:`plan_cut` does the three steps without writing an array, into a :class:`~.result.CutPlan`; the result is a
:class:`~.result.CutResult`.

A new vertex's rest position, current position and velocity are the same barycentric combination of its parent
triangle's (or edge's) corners (§7, Fig 8): the cut does not move anything. ``parents`` / ``weights`` give that
combination for every vertex of the result, in the numbering before the cut; old vertices keep their indices.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from ..errors import MeshError
from .fans import VertexFans, read_only
from .edges import edge_key
from .pieces import split_triangle
from .points import CutPoints
from .result import CutPlan, CutResult
from .row_patch import RowPatch
from .separate import rows_touching, separate
from .invariants import triangle_qualities
from .moves import NO_MOVES, VertexMoves, front_end, plan_moves, writable_rows
from .snapping import EXACT_MIN, GUARD_QUALITY, along_cut, exit_point, opposite_vertices
from .sweep import Sweep, candidate_triangles, check_snap, crossings

#: Default snap fraction of the local edge length (see :mod:`.sweep`).
DEFAULT_SNAP = 0.25


def cut_surface(rest: np.ndarray, positions: np.ndarray, velocities: np.ndarray, triangles: np.ndarray,
                sweep: Sweep, *, snap: float = DEFAULT_SNAP, closed: ArrayLike = (),
                movable: Callable[[np.ndarray], ArrayLike] | None = None) -> CutResult | None:
    """Cut M_S along one sweep; None when the sweep crosses no triangle (nothing changes).

    Returns new arrays (O(n + m) copies, and one pass over the triangles to find the sweep's): for a cut every frame
    use :class:`~tissuesim.cutting.buffers.CutSurface`, which edits capacity buffers in place.

    Args:
        rest, positions, velocities: ``(n, 3) float64`` rest positions [m], current positions [m] (the sweep is
            intersected with these), velocities [m/s].
        triangles: ``(m, 3) int`` triangles, counter-clockwise from outside.
        sweep: the blade's sweep in this move.
        snap: snap fraction of the local edge length, in [0, 1/3).
        closed: ``(p, 2)`` cut edges of earlier moves still shared by two triangles (:attr:`CutResult.closed`),
            so a cut that goes on from its tip opens there.
        movable: ``f(vertices (k,) int64) -> (k,) bool``: which vertices near the cut may be moved onto it
            (:mod:`.moves`; None: any inside the surface).

    Raises:
        MeshError: a cut segment could not be made an edge (a defect of the input mesh, e.g. a degenerate
            triangle); the inputs are unchanged.
    """
    snap = check_snap(snap)
    triangles = np.asarray(triangles, dtype=np.int32)      # no copy for a SurfaceMesh's triangles
    near = candidate_triangles(positions, triangles, sweep)
    # the fans of every vertex the cut can touch: the candidates' corners and the earlier tips' ends
    marked = np.zeros(len(rest), dtype=np.bool_)
    marked[triangles[near].ravel()] = True
    marked[np.asarray(closed, dtype=np.int64).ravel()] = True
    rows = rows_touching(triangles, marked)
    # copies: a move of a vertex onto the cut rewrites its rows
    rest, positions, velocities = (np.array(a, dtype=np.float64) for a in (rest, positions, velocities))
    plan = plan_cut(rest, positions, triangles, sweep, snap=snap, closed=closed,
                    fans=VertexFans(triangles[rows], len(rest), rows=rows), near=near, movable=movable)
    if plan is None:
        return None
    moved_from = rest[plan.moves.vertices]
    for array in (rest, positions, velocities):
        array[plan.moves.vertices] = plan.moves.values(array)
    new_rest, new_pos, new_vel = (np.concatenate([a, plan.interpolate(a)]) for a in (rest, positions, velocities))
    out = triangles.copy()
    for r, content in plan.patch.edited.items():
        out[r] = content
    out = np.concatenate([out, np.array(plan.patch.added, dtype=np.int32).reshape(-1, 3)])
    return plan.result(new_rest, new_pos, new_vel, out, sweep, moved_from=moved_from)


def plan_cut(rest: np.ndarray, positions: np.ndarray, triangles: np.ndarray, sweep: Sweep, *, snap: float,
             closed: ArrayLike, fans: VertexFans, near: np.ndarray,
             movable: Callable[[np.ndarray], ArrayLike] | None = None) -> CutPlan | None:
    """The cut of ``sweep`` among the candidate rows ``near`` (arrays as :func:`cut_surface`'s; ``fans`` must
    cover every vertex of ``near`` and of ``closed``); None if nothing is cut.

    The vertices near the cut that ``movable`` lets move are moved onto it first (:mod:`.moves`): ``rest`` and
    ``positions`` hold them there while the cut is planned (their rows are written, then put back), and the plan
    carries the moves (:attr:`CutPlan.moves`) for the caller to write with the rest. Otherwise writes nothing."""
    found = crossings(read_only(positions), triangles, sweep, near=near)
    if not found:
        return None
    moves = plan_moves(rest, positions, triangles, found, fans, snap=snap, closed=closed, movable=movable,
                       sweep=sweep)
    if not len(moves):
        return _plan(rest, positions, triangles, sweep, found, moves, snap=snap, closed=closed, fans=fans)
    held = [(writable_rows(a), moves.values(a), np.array(a[moves.vertices])) for a in (rest, positions)]
    try:
        for array, moved, _ in held:
            array[moves.vertices] = moved
        plan = _plan(rest, positions, triangles, sweep, crossings(read_only(positions), triangles, sweep, near=near),
                     moves, snap=snap, closed=closed, fans=fans)
        sound = plan is None or min(_worst_quality(plan, a) for a in (rest, positions)) >= GUARD_QUALITY
    finally:
        for array, _, before in held:
            array[moves.vertices] = before
    if sound:
        return plan
    # a case the moves do not foresee made a sliver: the cut without them (as snapping makes it) instead
    return _plan(rest, positions, triangles, sweep, found, NO_MOVES, snap=snap, closed=closed, fans=fans)


def _worst_quality(plan: CutPlan, points: np.ndarray) -> float:
    """The smallest quality of the rows ``plan`` writes, with its new points interpolated in ``points`` (n, 3)."""
    rows = np.array(list(plan.patch.edited.values()) + plan.patch.added, dtype=np.int64).reshape(-1, 3)
    if not len(rows):
        return np.inf
    where = np.concatenate([points[: plan.old_count], plan.interpolate(points)])
    return float(triangle_qualities(where, rows).min())


def _plan(rest, positions, triangles, sweep, found, moves: VertexMoves, *, snap, closed, fans) -> CutPlan | None:
    """:func:`plan_cut` on the crossings ``found``, with the vertices ``moves`` already on the cut."""
    if not found:
        return None
    rest, positions, triangles = (read_only(a) for a in (rest, positions, triangles))
    n, m = len(rest), len(triangles)
    patch = RowPatch(triangles, fans, n)
    points = CutPoints(n=n, snap=snap, rest=rest, now=positions)
    segments, known_sides = {}, {}
    moved = set(moves.vertices.tolist())
    for crossing in found:
        corners = triangles[crossing.triangle]
        along = (_onto_moved_corner(crossing.ends, corners, moved, front_end(crossing.ends, corners, positions, sweep))
                 if moved else crossing.ends)
        opposite = opposite_vertices(patch, corners.tolist(), along, snap, known_sides)
        ends = [points.locate(corners, crossing.triangle, w, opposite) for w in along]
        # a facet end snapped across the trace by more than a small weight goes along it instead (less than
        # EXACT_MIN of the triangle's height off the trace is as close as an exact point's quality allows)
        across = [e for e in range(2) if np.count_nonzero(along[e]) == 3 and ends[e][0] != "f"
                  and _snapped_off(along[e], ends[e], corners) >= EXACT_MIN]
        if across:
            along = along_cut(along, across)
            opposite = opposite_vertices(patch, corners.tolist(), along, snap, known_sides)
            ends = [points.locate(corners, crossing.triangle, w, opposite) for w in along]
        if points.same(*ends):
            continue            # the segment snapped to a point: nothing to cut in this triangle
        a, b = (points.commit(corners, end) for end in ends)
        if a != b:
            segments[crossing.triangle] = (a, b)
    if not points.parents and not segments:
        return None
    affected = _affected(segments, points, patch)
    # a moved vertex's rows keep their corners but change shape: the solvers make their rest data again
    moved_rows = sorted({r for v in moves.vertices.tolist() for r in patch.fan(v)})
    for r in moved_rows:
        if r not in patch.edited:
            patch.write(r, patch.row_list(r))
    parents = np.array(points.parents, dtype=np.int64).reshape(-1, 3)
    weights = np.array(points.weights, dtype=np.float64).reshape(-1, 3)
    origin, cut_edges = [], set()
    for t in affected:
        pieces, cut = split_triangle(t, triangles[t], rest, points, segments.get(t), snap)
        patch.write(t, pieces[0])
        patch.append(pieces[1:])
        origin += [t] * (len(pieces) - 1)
        cut_edges |= cut
    new_rows = affected + list(range(m, m + len(patch.added)))
    _check_edges(np.array([patch.row_list(r) for r in new_rows]), sorted(cut_edges), affected)
    # earlier tips that are no longer edges (a later cut went through them) are ignored by separate()
    cut_list = sorted(cut_edges | _carry_closed(closed, points))
    copy_of, still_closed, rewritten = separate(patch, cut_list, n + len(parents))
    # a copy of an old vertex interpolates that vertex alone; a copy of an inserted point takes its parents
    copy_parents = np.repeat(copy_of[:, None], 3, axis=1)
    copy_weights = np.zeros((len(copy_of), 3))
    copy_weights[:, 0] = 1.0
    inserted = copy_of >= n
    copy_parents[inserted] = parents[copy_of[inserted] - n]
    copy_weights[inserted] = weights[copy_of[inserted] - n]
    changed = np.unique(np.concatenate([np.array(new_rows + moved_rows, dtype=np.int64), rewritten]))
    return CutPlan(old_count=n, parents=np.concatenate([parents, copy_parents]),
                   weights=np.concatenate([weights, copy_weights]),
                   new_copy_of=np.concatenate([np.full(len(parents), -1, dtype=np.int64), copy_of]),
                   patch=patch, origin=origin, changed=changed,
                   replaced=np.array(triangles[changed[changed < m]], dtype=np.int64), cut_list=cut_list,
                   still_closed=still_closed, split_count=len(affected), segments=segments, moves=moves)


def _onto_moved_corner(ends: np.ndarray, corners, moved: set, front: int) -> np.ndarray:
    """``(2, 3)`` ``ends`` with the ``front`` end (the one farther along the move), a facet point, taken on to the
    corner its segment's line leaves the triangle by, where that corner was moved onto the cut: the corner, the end
    and the segment are on one line, and a piece joining them would have no area."""
    out = np.array(ends, dtype=np.float64)
    for e in (front,):
        if np.count_nonzero(out[e] > 0.0) < 3:
            continue
        leave, _ = exit_point(out[1 - e], out[e])
        k = int(np.argmax(leave))
        if leave[k] > 1.0 - 1e-9 and int(corners[k]) in moved:
            out[e] = 0.0
            out[e, k] = 1.0
    return out


def _snapped_off(weights: np.ndarray, located: tuple, corners) -> float:
    """The barycentric weight a located point dropped from ``weights`` (3,) in the triangle ``corners``."""
    if located[0] == "v":
        return 1.0 - float(weights[list(corners).index(located[1])])
    kept = [k for k in range(3) if corners[k] in located[1:3]]
    return float(1.0 - weights[kept].sum())


def _affected(segments, points, patch) -> list[int]:
    """Triangles with a segment, or with an edge point on a side (both triangles of its edge, from the fans)."""
    affected = set(segments)
    for lo, hi in points.edge:
        affected.update(patch.owners(lo, hi))
    return sorted(affected)


def _carry_closed(closed, points):
    """Earlier cuts' closed edges, with any edge point inserted on them now (the edge became two)."""
    edges = set()
    for u, v in np.asarray(closed, dtype=np.int64).reshape(-1, 2):
        lo, hi = edge_key(u, v)
        chain = [lo] + [pid for _, pid in sorted(points.edge.get((lo, hi), []))] + [hi]
        edges |= {edge_key(p, q) for p, q in zip(chain, chain[1:])}
    return edges


def _check_edges(pieces, cut_edges, affected) -> None:
    """Every cut edge must be an edge of the new pieces (the subdivision guarantees it; this guards it)."""
    if not cut_edges:
        return
    present = {edge_key(u, v) for u, v in pieces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).tolist()}
    missing = [e for e in cut_edges if e not in present]
    if missing:
        raise MeshError(f"{len(missing)} cut segments are not edges after subdivision (first: {missing[0]}, "
                        f"triangles split: {len(affected)}); the mesh near the cut is degenerate, repair it")

