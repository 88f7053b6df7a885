"""Snapping a cut point in its triangle, and the quality guard that snaps it further (§7 is silent on both).

A crossing's end arrives as barycentric weights in a triangle. Weights below the snap fraction σ are dropped (the
point goes onto the edge or vertex beside it, see :mod:`.sweep`). The guard then snaps further while a piece the
point would make falls below :data:`GUARD_QUALITY` at rest or at the current positions (a cut on a deformed
surface): a facet point onto the edge of its worst piece, an edge point onto the nearer end. Repeated re-cuts would
otherwise thin the triangles step by step. Compiled: it runs for both ends of every crossing.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from .edges import edge_key

if TYPE_CHECKING:
    from .row_patch import RowPatch

#: A new point is snapped further (facet → edge → vertex) while it would make a piece of lower quality than this
#: (4√3 A / Σ l², at rest) in the triangle it lies in: twice the invariants' floor, so later cuts have room.
GUARD_QUALITY = 0.02
#: A point closer than the snap fraction to a vertex or an edge (a vertex that cannot be moved onto the cut, see
#: :mod:`.moves`) stays where the blade crossed while every weight it has is at least this and every piece it makes
#: keeps :data:`EXACT_QUALITY`: snapped, the cut would leave the blade's trace by up to σ of an edge.
EXACT_MIN = 0.1
EXACT_QUALITY = 0.1


def along_cut(ends: np.ndarray, which: Iterable[int]) -> np.ndarray:
    """``(2, 3)`` the barycentric ``ends`` of a crossing segment with each facet end of ``which`` moved along the
    segment instead of snapping across it: forward to where the segment's line leaves the triangle
    (:func:`exit_point`), when that is nearer than the other end, else back to the other end (this triangle's piece
    of the cut is then left to a later move). Snapping across would put the cut's tip beside the blade's trace, and
    the next move, which goes on from that tip, would turn the wound toward it."""
    out = np.array(ends, dtype=np.float64)
    for e in which:
        tip, other = out[e], out[1 - e]
        if np.count_nonzero(tip > 0.0) < 3:
            continue
        leave, at = exit_point(other, tip)
        out[e] = leave if at - 1.0 < 1.0 else other
    return out


def exit_point(start: np.ndarray, through: np.ndarray) -> tuple[np.ndarray, float]:
    """``((3,) weights, λ)``: where the line from barycentric ``start`` through ``through`` leaves the triangle,
    at ``start + λ (through − start)``, exactly on that side (λ = inf and ``through`` if it never does)."""
    step = through - start
    falling = step < 0.0
    if not falling.any():
        return np.array(through, dtype=np.float64), np.inf
    at = float(np.min(start[falling] / -step[falling]))
    leave = start + at * step
    leave[np.argmin(leave)] = 0.0                    # on the side it leaves by, exactly
    return leave / leave.sum(), at


def opposite_vertices(patch: RowPatch, corners: list[int], ends: np.ndarray, snap: float, known: dict) -> np.ndarray:
    """``(3, w) int64`` for each side (k, k + 1) of the triangle ``corners``, the vertices opposite that side in the
    rows of ``patch`` that hold it (an edge point there splits all of them, Fig 7(a)); −1 pads.

    Only the sides the guard can reach from the barycentric ``ends`` ``(2, 3)`` are looked up: an edge point's side,
    or all three for a facet point; the others get the triangle's own corner. ``known`` caches sides by edge."""
    kept = [[x >= min(snap, EXACT_MIN) for x in w] for w in ends.tolist()]
    if any(all(row) for row in kept):
        reachable = {0, 1, 2}
    else:
        reachable = {k for row in kept for k in range(3) if row[k] and row[(k + 1) % 3]}
    sides = []
    for k in range(3):
        u, v = corners[k], corners[(k + 1) % 3]
        key = edge_key(u, v)
        others = known.get(key) if k in reachable else [corners[(k + 2) % 3]]
        if others is None:
            others = known[key] = [o for r in patch.owners(*key) for o in patch.row_list(r) if o != u and o != v]
        sides.append(others or [corners[(k + 2) % 3]])
    out = np.full((3, max(2, max(len(s) for s in sides))), -1, dtype=np.int64)
    for k, others in enumerate(sides):
        out[k, :len(others)] = others
    return out


@njit(cache=True)
def snapped_weights(rest: np.ndarray, now: np.ndarray, corners: np.ndarray, weights: np.ndarray, opposite: np.ndarray,
                    snap: float) -> np.ndarray:
    """``(3,) float64`` the barycentric ``weights`` of a point in the triangle ``corners`` after snapping by ``snap``
    and the quality guard, at rest positions ``rest`` and current positions ``now`` ``(n, 3)`` [m]; ``opposite`` from
    :func:`opposite_vertices`. Zero weights mark the corners the point is not on."""
    quality = np.empty(6 * opposite.shape[1])
    if _stays_exact(rest, now, corners, weights, opposite, quality):
        return weights.copy()
    w = np.zeros(3)
    for k in range(3):
        if weights[k] >= snap:
            w[k] = weights[k]
    _normalise(w)
    while (w[0] != 0.0) + (w[1] != 0.0) + (w[2] != 0.0) > 1:
        for k in range(quality.size):
            quality[k] = np.inf
        _piece_qualities(rest, corners, w, opposite, quality)
        _piece_qualities(now, corners, w, opposite, quality)
        lowest = np.inf
        for q in quality:
            lowest = min(lowest, q)
        if lowest >= GUARD_QUALITY:
            break
        if w[0] != 0.0 and w[1] != 0.0 and w[2] != 0.0:
            worst = 0
            for i in range(1, 3):
                if quality[i] < quality[worst]:
                    worst = i
            w[(worst + 2) % 3] = 0.0                # onto the worst piece's edge (worst, worst + 1)
        else:
            i, j = _inside_pair(w)
            w[i if w[i] < w[j] else j] = 0.0        # onto the nearer end
        _normalise(w)
    return w


@njit(cache=True)
def _stays_exact(rest, now, corners, weights, opposite, quality):
    """Whether an edge or facet point whose non-zero weights are all at least :data:`EXACT_MIN` keeps every piece
    it makes at quality ≥ :data:`EXACT_QUALITY`, at rest and now (``quality`` is a work array)."""
    inside = 0
    for k in range(3):
        if weights[k] > 0.0:
            inside += 1
            if weights[k] < EXACT_MIN:
                return False
    if inside < 2:
        return False
    for k in range(quality.size):
        quality[k] = np.inf
    _piece_qualities(rest, corners, weights, opposite, quality)
    _piece_qualities(now, corners, weights, opposite, quality)
    for q in quality:
        if q < EXACT_QUALITY:
            return False
    return True


@njit(cache=True)
def _normalise(w):
    total = w[0] + w[1] + w[2]
    for k in range(3):
        w[k] /= total


@njit(cache=True)
def _inside_pair(w):
    """The two corners with non-zero weight, ascending (of an edge point)."""
    i = 0 if w[0] != 0.0 else 1
    j = 2 if w[2] != 0.0 else 1
    return i, j


@njit(cache=True)
def _piece_qualities(where, corners, w, opposite, quality):
    """Lower ``quality`` to the qualities of the pieces a point at ``w`` would make, with vertices at ``where``:
    three in its triangle for a facet point (piece i on side (i, i + 1), at ``quality[i]``), two per triangle of
    its side for an edge point."""
    x = np.zeros(3)
    for k in range(3):
        x[k] = w[0] * where[corners[0], k] + w[1] * where[corners[1], k] + w[2] * where[corners[2], k]
    if w[0] != 0.0 and w[1] != 0.0 and w[2] != 0.0:
        for i in range(3):
            quality[i] = min(quality[i], _quality3(x, where[corners[i]], where[corners[(i + 1) % 3]]))
        return
    i, j = _inside_pair(w)
    side = i if (i + 1) % 3 == j else j         # the side (k, k + 1) the point lies on
    slot = 0
    for o in opposite[side]:
        if o < 0:
            break
        quality[slot] = min(quality[slot], _quality3(x, where[corners[i]], where[o]))
        quality[slot + 1] = min(quality[slot + 1], _quality3(x, where[corners[j]], where[o]))
        slot += 2


@njit(cache=True)
def _quality3(a, b, c):
    """4√3 A / (|ab|² + |bc|² + |ca|²) of a triangle in 3-D: 1 equilateral, 0 degenerate."""
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    vx, vy, vz = c[0] - a[0], c[1] - a[1], c[2] - a[2]
    wx, wy, wz = c[0] - b[0], c[1] - b[1], c[2] - b[2]
    squares = ux * ux + uy * uy + uz * uz + vx * vx + vy * vy + vz * vz + wx * wx + wy * wy + wz * wz
    if squares <= 0.0:
        return 0.0
    cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    return 2.0 * math.sqrt(3.0) * math.sqrt(cx * cx + cy * cy + cz * cz) / squares
