"""§7: where the tool's sweep surface crosses the fine surface M_S (edge points and facet points).

The blade is the segment of length ``depth`` from the tool tip along a fixed direction d (chosen at the press). One
``move`` from tip x0 to tip x1 sweeps the parallelogram ``x0 + s (x1 − x0) + t depth d``, s, t ∈ [0, 1]: planar,
so it crosses each triangle in at most one segment and each edge at most once. Each crossing segment is returned in
the triangle's barycentric coordinates; the ends lie on an edge (the paper's *edge points*) or, where the
parallelogram's border stops inside the triangle, inside it (*facet points*). Barycentric coordinates carry the
points to the rest surface unchanged (§7, Fig 8).

Snapping (the paper is silent): with ``snap`` = σ, an edge point within σ × the edge's length of an end goes onto
that vertex, and a facet point whose weight on a corner is below σ (closer to the opposite edge than σ × the
triangle's height there) goes onto that edge (or, for two such weights, onto the vertex). No new point is therefore
closer than that to an existing vertex or edge, which bounds the aspect ratio of the sub-triangles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

from ..errors import SolverError

#: Relative tolerance [1] under which a vertex counts as lying on the sweep plane (fraction of the edge length).
PLANE_TOLERANCE = 1e-9


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
    def between(cls, tip0, tip1, blade) -> "Sweep":
        """The sweep from tip ``tip0`` to ``tip1`` ``(3,)`` [m] of a blade vector ``blade`` ``(3,)`` [m]."""
        tip0, tip1, blade = (np.asarray(a, dtype=np.float64).reshape(3) for a in (tip0, tip1, blade))
        return cls(tip0, tip1 - tip0, blade)

    @property
    def normal(self) -> np.ndarray:
        """``(3,) float64`` unit normal of the sweep plane (zero when the tip moved along the blade)."""
        n = np.cross(self.u, self.v)
        length = np.linalg.norm(n)
        return n / length if length > 0.0 else n

    @property
    def corners(self) -> np.ndarray:
        """``(4, 3) float64`` the parallelogram's corners: tip0, tip1, back1, back0 [m]."""
        o, u, v = self.origin, self.u, self.v
        return np.stack([o, o + u, o + u + v, o + v])

    @cached_property
    def _dual(self) -> np.ndarray:
        """``(3, 2)`` the dual basis of (u, v) in their plane: (x − origin) @ dual = (s, t) (made once per sweep,
        which projects a point per crossing)."""
        gram = np.array([[self.u @ self.u, self.u @ self.v], [self.u @ self.v, self.v @ self.v]])
        return np.stack([self.u, self.v], axis=1) @ np.linalg.inv(gram)

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
    return _candidates(positions, triangles, corners.min(axis=0) - pad, corners.max(axis=0) + pad)


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
    out = []
    near = candidate_triangles(positions, triangles, sweep) if near is None else near
    p = positions[triangles[near]]
    d = (p - sweep.origin) @ normal
    reach = PLANE_TOLERANCE * np.abs(p - p[:, [1, 2, 0]]).sum(axis=(1, 2))
    straddling = near[(d.min(axis=1) <= reach) & (d.max(axis=1) >= -reach)]    # the plane passes through
    for t in straddling:
        ends = _plane_segment(positions, triangles[t], sweep.origin, normal)
        if ends is None:
            continue
        clipped = _clip(ends, positions[triangles[t]], sweep)
        if clipped is not None:
            out.append(Crossing(int(t), clipped))
    return out


def _plane_segment(positions, corners, origin, normal):
    """``(2, 3)`` barycentric ends of the triangle ∩ plane segment, or None (no crossing, a point, coplanar).
    Plain floats: three points per triangle, where array calls would cost more than the arithmetic."""
    p = positions[corners].tolist()
    o, n = origin.tolist(), normal.tolist()
    scale = max(math.dist(p[1], p[0]), math.dist(p[2], p[1]), math.dist(p[0], p[2]))
    d = [(x[0] - o[0]) * n[0] + (x[1] - o[1]) * n[1] + (x[2] - o[2]) * n[2] for x in p]
    d = [0.0 if abs(x) <= PLANE_TOLERANCE * scale else x for x in d]
    if not any(d):
        return None
    points = [[1.0 if k == i else 0.0 for k in range(3)] for i in range(3) if d[i] == 0.0]
    ids = corners.tolist()
    for i, j in ((0, 1), (1, 2), (2, 0)):
        if d[i] * d[j] < 0.0:
            lo, hi = (i, j) if ids[i] < ids[j] else (j, i)
            t = d[lo] / (d[lo] - d[hi])
            w = [0.0, 0.0, 0.0]
            w[lo], w[hi] = 1.0 - t, t
            points.append(w)
    if len(points) != 2:
        return None
    return np.array(points)


def _clip(ends, corners_xyz, sweep):
    """Clip a segment (barycentric ends) to the parallelogram s, t ∈ [0, 1] (Liang–Barsky); None if outside."""
    st = sweep.plane_coordinates(ends @ corners_xyz)
    start, delta = st[0], st[1] - st[0]
    lo, hi = 0.0, 1.0
    for k in range(2):
        for bound, sign in ((0.0, 1.0), (1.0, -1.0)):
            # keep sign * (start + λ delta − bound) ≥ 0
            a, b = sign * delta[k], sign * (start[k] - bound)
            if a == 0.0:
                if b < 0.0:
                    return None
                continue
            root = -b / a
            if a > 0.0:
                lo = max(lo, root)
            else:
                hi = min(hi, root)
    if hi - lo <= 0.0:
        return None
    return np.stack([ends[0] + lo * (ends[1] - ends[0]), ends[0] + hi * (ends[1] - ends[0])])


def check_snap(snap: float) -> float:
    """``snap`` as a float in [0, 1/3), or a SolverError saying so."""
    try:
        snap = float(snap)
    except (TypeError, ValueError):
        raise SolverError(f"snap must be a fraction of the local edge length in [0, 1/3), got {snap!r}") from None
    if not 0.0 <= snap < 1.0 / 3.0:
        raise SolverError(f"snap must be a fraction of the local edge length in [0, 1/3), got {snap!r}")
    return snap
