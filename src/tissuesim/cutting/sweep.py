"""§7: where the tool's sweep surface crosses the fine surface M_S (edge points and facet points).

The blade is the segment of length ``depth`` from the tool tip along a fixed direction d (chosen at the press). One
``move`` from tip x0 to tip x1 sweeps the parallelogram ``x0 + s (x1 − x0) + t depth d``, s, t ∈ [0, 1]: planar,
so it crosses each triangle in at most one segment and each edge at most once. Each crossing segment is returned in
the triangle's barycentric coordinates; the ends lie on an edge (the paper's *edge points*) or, where the
parallelogram's border stops inside the triangle, inside it (*facet points*). Barycentric coordinates carry the
points to the rest surface unchanged (§7, Fig 8).

Snapping (the paper is silent): with ``snap`` = σ in [:data:`MIN_SNAP`, 1/3), an edge point within σ × the edge's
length of an end goes onto that vertex, and a facet point whose weight on a corner is below σ (closer to the
opposite edge than σ × the triangle's height there) goes onto that edge (or, for two such weights, onto the vertex).
No new point is therefore closer than that to an existing vertex or edge, which bounds the aspect ratio of the
sub-triangles; points of one move closer than that to each other are merged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit
from numpy.typing import ArrayLike

from ..errors import SolverError
from ..numba_cache import kernel_view
from ..loads import real_number

#: Relative tolerance [1] under which a vertex counts as lying on the sweep plane (fraction of the edge length).
PLANE_TOLERANCE = 1e-9
#: Relative margin [1] by which the sweep's parallelogram is grown when a crossing is clipped to it.
CLIP_TOLERANCE = 1e-9
#: Smallest snap fraction accepted. Snapping also sets how close two cut points of one move may come before they
#: are merged, so at 0 two crossings at one place make two vertices there: zero-length edges, zero-area triangles
#: and non-manifold vertices (at 0 every random move on the cube was refused or broke the surface). Below the
#: quality guard's reach, slivers between two new points remain: random 12-move strokes on the cube (20 per seed,
#: ~240 moves, mass-spring and embedded) left a triangle of quality 0.0074 (below the invariants' 0.01) with 0.05 in
#: 4 of 10 seeds and with 0.1 in 1 of 16; 0.001 left slivers in 5 of 25 strokes. 0.15 left none in 25 seeds (~5,900
#: moves, every method).
MIN_SNAP = 0.15


@dataclass(frozen=True)
class Sweep:
    """The planar parallelogram swept by the blade in one move: ``origin + s u + t v``, s, t ∈ [0, 1].

    Attributes:
        origin: ``(3,) float64`` tool tip at the start of the move [m].
        u: ``(3,) float64`` tip motion x1 − x0 [m].
        v: ``(3,) float64`` blade vector depth × d [m] (from the tip into the tissue).
    """

    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray

    @classmethod
    def between(cls, tip0: ArrayLike, tip1: ArrayLike, blade: ArrayLike) -> "Sweep":
        """The sweep from tip ``tip0`` to ``tip1`` ``(3,)`` [m] of a blade vector ``blade`` ``(3,)`` [m]."""
        tip0, tip1, blade = (np.asarray(a, dtype=np.float64).reshape(3) for a in (tip0, tip1, blade))
        return cls(tip0, tip1 - tip0, blade)

    @cached_property
    def normal(self) -> np.ndarray:
        """``(3,) float64`` unit normal of the sweep plane (zero when the tip moved along the blade)."""
        (ux, uy, uz), (vx, vy, vz) = self.u.tolist(), self.v.tolist()
        n = (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx)
        length = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
        return np.array(n) / length if length > 0.0 else np.array(n)

    @property
    def corners(self) -> np.ndarray:
        """``(4, 3) float64`` the parallelogram's corners: tip0, tip1, back1, back0 [m]."""
        o, u, v = self.origin, self.u, self.v
        return np.stack([o, o + u, o + u + v, o + v])

    @cached_property
    def _dual(self) -> np.ndarray:
        """``(3, 2)`` the dual basis of (u, v) in their plane: (x − origin) @ dual = (s, t) (made once per sweep,
        which projects a point per crossing)."""
        u, v = self.u, self.v
        uu, uv, vv = float(u @ u), float(u @ v), float(v @ v)
        det = uu * vv - uv * uv
        return np.stack([(vv * u - uv * v) / det, (uu * v - uv * u) / det], axis=1)

    def plane_coordinates(self, points: np.ndarray) -> np.ndarray:
        """``(k, 2) float64`` (s, t) of ``points`` ``(k, 3)`` [m] projected onto the sweep plane."""
        return (points - self.origin) @ self._dual


@dataclass(frozen=True)
class Crossing:
    """One segment of a triangle cut by the sweep, before snapping.

    Attributes:
        triangle: the triangle's row in the triangle array.
        ends: ``(2, 3) float64`` barycentric coordinates of the segment's two ends in that triangle.
    """

    triangle: int
    ends: np.ndarray


@njit(cache=True)
def _candidates(positions, triangles, low, high):
    """Triangles whose bounding box overlaps the box [low, high] (one pass, no allocation but the result)."""
    keep = np.zeros(triangles.shape[0], dtype=np.bool_)
    for t in range(triangles.shape[0]):
        inside = True
        for k in range(3):
            a = positions[triangles[t, 0], k]
            b = positions[triangles[t, 1], k]
            c = positions[triangles[t, 2], k]
            if min(a, b, c) > high[k] or max(a, b, c) < low[k]:
                inside = False
                break
        keep[t] = inside
    return np.flatnonzero(keep)


def candidate_triangles(positions: np.ndarray, triangles: np.ndarray, sweep: Sweep, *,
                        pad: float = 0.0) -> np.ndarray:
    """``(k,) int64`` rows of ``triangles`` whose bounding box (at ``positions`` [m]) overlaps the sweep's, grown
    by ``pad`` [m]."""
    corners = sweep.corners
    pad = pad + 1e-9 * (np.ptp(corners, axis=0).max() + 1e-300)
    return triangles_in_box(positions, triangles, corners.min(axis=0) - pad, corners.max(axis=0) + pad)


def triangles_in_box(positions: np.ndarray, triangles: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """``(k,) int64`` rows of ``triangles`` whose bounding box (at ``positions`` ``(n, 3)`` [m]) overlaps the box
    [``low``, ``high``] ``(3,)`` [m] (one compiled pass)."""
    return _candidates(positions, triangles, np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64))


def crossings(positions: np.ndarray, triangles: np.ndarray, sweep: Sweep, *,
              near: np.ndarray | None = None) -> list[Crossing]:
    """The segments where the sweep crosses M_S's triangles at their current ``positions`` ``(n, 3)`` [m].

    A triangle lying in the sweep plane, or touching it in one point, gives none. Edge crossings are computed from
    the edge's lower-numbered vertex, so the two triangles of an edge agree on the point bit for bit. ``near``:
    the rows to search (default :func:`candidate_triangles`).
    """
    normal = sweep.normal
    if not np.any(normal):
        return []
    near = candidate_triangles(positions, triangles, sweep) if near is None else near
    arrays = (positions, triangles, np.asarray(near, dtype=np.int64), sweep.origin, normal, sweep._dual)
    rows, ends = _crossing_segments(*map(kernel_view, arrays), PLANE_TOLERANCE)
    return [Crossing(t, e) for t, e in zip(rows.tolist(), ends)]


@njit(cache=True)
def _crossing_segments(positions, triangles, near, origin, normal, dual, tolerance):
    """``(rows (k,) int64, ends (k, 2, 3))``: the rows of ``near`` the sweep plane crosses in a segment, and the
    barycentric ends of that segment clipped to the parallelogram (one compiled pass over the candidates)."""
    rows = np.empty(near.size, dtype=np.int64)
    ends = np.empty((near.size, 2, 3))
    count = 0
    w = np.empty((2, 3))
    for q in range(near.size):
        t = near[q]
        if _plane_segment(positions, triangles[t], origin, normal, tolerance, w) and \
                _clip(w, positions, triangles[t], origin, dual):
            rows[count] = t
            for e in range(2):
                for k in range(3):
                    ends[count, e, k] = w[e, k]
            count += 1
    return rows[:count], ends[:count]


@njit(cache=True)
def _plane_segment(positions, corners, origin, normal, tolerance, out):
    """Write into ``out`` ``(2, 3)`` the barycentric ends of the triangle ∩ plane segment; False when there is
    none (no crossing, a single point, or the triangle lies in the plane)."""
    d = np.empty(3)
    scale = 0.0
    for i in range(3):
        a, b = positions[corners[i]], positions[corners[(i + 1) % 3]]
        scale = max(scale, math.sqrt((b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2 + (b[2] - a[2]) ** 2))
        x = positions[corners[i]]
        d[i] = (x[0] - origin[0]) * normal[0] + (x[1] - origin[1]) * normal[1] + (x[2] - origin[2]) * normal[2]
    for i in range(3):
        if abs(d[i]) <= tolerance * scale:
            d[i] = 0.0
    if d[0] == 0.0 and d[1] == 0.0 and d[2] == 0.0:
        return False
    found = 0
    out[:] = 0.0
    for i in range(3):
        if d[i] == 0.0:
            if found == 2:
                return False
            out[found, i] = 1.0
            found += 1
    for i in range(3):
        j = (i + 1) % 3
        if d[i] * d[j] < 0.0:
            if found == 2:
                return False
            lo, hi = (i, j) if corners[i] < corners[j] else (j, i)
            t = d[lo] / (d[lo] - d[hi])
            out[found, lo], out[found, hi] = 1.0 - t, t
            found += 1
    return found == 2


@njit(cache=True)
def _clip(ends, positions, corners, origin, dual):
    """Clip the segment of barycentric ``ends`` ``(2, 3)`` to the parallelogram s, t ∈ [0, 1] (Liang–Barsky), in
    place; False if nothing is left."""
    st = np.zeros((2, 2))
    for e in range(2):
        for k in range(3):
            x = (ends[e, 0] * positions[corners[0], k] + ends[e, 1] * positions[corners[1], k]
                 + ends[e, 2] * positions[corners[2], k]) - origin[k]
            st[e, 0] += x * dual[k, 0]
            st[e, 1] += x * dual[k, 1]
    lo, hi = 0.0, 1.0
    for k in range(2):
        start, delta = st[0, k], st[1, k] - st[0, k]
        # keep −ε ≤ start + λ delta ≤ 1 + ε: a segment along the sweep's border (a cut going on from its tip
        # with the blade's tip at the surface) stays, whatever the round-off of its coordinates there
        inside, lo, hi = _clip_bound(delta, start + CLIP_TOLERANCE, lo, hi)
        if not inside:
            return False
        inside, lo, hi = _clip_bound(-delta, 1.0 + CLIP_TOLERANCE - start, lo, hi)
        if not inside:
            return False
    if hi - lo <= 0.0:
        return False
    for k in range(3):
        first, step = ends[0, k], ends[1, k] - ends[0, k]
        ends[0, k] = first + lo * step
        ends[1, k] = first + hi * step
    return True


@njit(cache=True)
def _clip_bound(a, b, lo, hi):
    """Liang–Barsky on one bound, a λ + b ≥ 0: whether any λ is left, and the new [lo, hi]."""
    if a == 0.0:
        return b >= 0.0, lo, hi
    root = -b / a
    if a > 0.0:
        return True, max(lo, root), hi
    return True, lo, min(hi, root)


def check_snap(snap: float) -> float:
    """``snap`` as a float in [:data:`MIN_SNAP`, 1/3), or a SolverError naming the option, the range and why."""
    value = real_number(snap)      # no text: "0.2" would otherwise be read as 0.2
    value = math.nan if value is None else value
    if not MIN_SNAP <= value < 1.0 / 3.0:
        why = (f"; below {MIN_SNAP:g} the cut's points are merged only when closer than snap x the edge, which "
               "leaves slivers (at 0, coincident vertices and zero-area triangles)") if 0.0 <= value < MIN_SNAP else ""
        raise SolverError(f"the scalpel's snap option must be a fraction of the local edge length in "
                          f"[{MIN_SNAP:g}, 1/3), got {snap!r}{why}; pass a snap from {MIN_SNAP:g} up to below 1/3 "
                          "(default 0.25)")
    return value
