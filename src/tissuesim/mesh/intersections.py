"""Self-intersections of a triangle surface (Devillers–Guigue orientation predicates in plain float64, no exact
arithmetic), for the surface validation of :mod:`tissuesim.mesh.validate`.

Triangle pairs sharing no vertex intersect if they share any point (touching counts); pairs sharing one vertex
intersect if they share any point other than that vertex (tested by the edge opposite the shared vertex of each
against the other triangle, which is complete: see :func:`_pair_intersects`); pairs sharing an edge
intersect only if they are coplanar (orientation exactly 0.0) and folded onto each other; pairs with the same
three vertices (duplicate faces) always intersect. Broad phase: the triangles' bounding boxes in a uniform grid
(cell side twice the median box size), each overlapping pair tested once, in Numba.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .surface import SurfaceMesh

# Every predicate takes the vertex array and vertex *indices*, and each is called from one place with permuted
# indices rather than from many places with permuted arguments: Devillers-Guigue's branch tables written as nested
# calls make LLVM inline dozens of copies (minutes of compile time); this form compiles in seconds.


@njit(cache=True)
def _orient3d(v, a, b, c, d):
    """``(d - c) . ((a - c) x (b - c))`` for rows of ``v``: positive when ``d`` lies on the side that triangle
    ``abc``'s right-hand normal points to. The sign convention of Devillers and Guigue's reference code."""
    ax, ay, az = v[a, 0] - v[c, 0], v[a, 1] - v[c, 1], v[a, 2] - v[c, 2]
    bx, by, bz = v[b, 0] - v[c, 0], v[b, 1] - v[c, 1], v[b, 2] - v[c, 2]
    dx, dy, dz = v[d, 0] - v[c, 0], v[d, 1] - v[c, 1], v[d, 2] - v[c, 2]
    return dx * (ay * bz - az * by) + dy * (az * bx - ax * bz) + dz * (ax * by - ay * bx)


@njit(cache=True)
def _project(v, rows, a, b, c):
    """``(k, 2)`` coordinates of ``v[rows]`` in the axis plane dropping the dominant axis of triangle ``abc``'s
    normal (the projection that keeps the triangle least distorted)."""
    ux, uy, uz = v[b, 0] - v[a, 0], v[b, 1] - v[a, 1], v[b, 2] - v[a, 2]
    wx, wy, wz = v[c, 0] - v[a, 0], v[c, 1] - v[a, 1], v[c, 2] - v[a, 2]
    nx, ny, nz = abs(uy * wz - uz * wy), abs(uz * wx - ux * wz), abs(ux * wy - uy * wx)
    drop = 0 if (nx >= ny and nx >= nz) else (1 if ny >= nz else 2)
    P = np.empty((len(rows), 2))
    for k in range(len(rows)):
        P[k, 0] = v[rows[k], (drop + 1) % 3]
        P[k, 1] = v[rows[k], (drop + 2) % 3]
    return P


@njit(cache=True)
def _orient2d(P, a, b, c):
    return (P[a, 0] - P[c, 0]) * (P[b, 1] - P[c, 1]) - (P[a, 1] - P[c, 1]) * (P[b, 0] - P[c, 0])


@njit(cache=True)
def _on_segment_2d(P, a, b, p):
    """Row ``p``, known collinear with rows ``a``-``b``, lies within the segment's bounding box."""
    return (min(P[a, 0], P[b, 0]) <= P[p, 0] <= max(P[a, 0], P[b, 0])
            and min(P[a, 1], P[b, 1]) <= P[p, 1] <= max(P[a, 1], P[b, 1]))


@njit(cache=True)
def _segments_intersect_2d(P, p, q, a, b):
    """Closed 2D segments ``pq`` and ``ab`` (rows of ``P``) share a point."""
    d1 = _orient2d(P, a, b, p)
    d2 = _orient2d(P, a, b, q)
    d3 = _orient2d(P, p, q, a)
    d4 = _orient2d(P, p, q, b)
    if ((d1 > 0 and d2 < 0) or (d1 < 0 and d2 > 0)) and ((d3 > 0 and d4 < 0) or (d3 < 0 and d4 > 0)):
        return True
    # Touching or collinear: an endpoint lies on the other segment.
    return ((d1 == 0 and _on_segment_2d(P, a, b, p)) or (d2 == 0 and _on_segment_2d(P, a, b, q))
            or (d3 == 0 and _on_segment_2d(P, p, q, a)) or (d4 == 0 and _on_segment_2d(P, p, q, b)))


@njit(cache=True)
def _point_in_triangle_2d(P, p, a, b, c):
    d1 = _orient2d(P, a, b, p)
    d2 = _orient2d(P, b, c, p)
    d3 = _orient2d(P, c, a, p)
    return not ((d1 < 0 or d2 < 0 or d3 < 0) and (d1 > 0 or d2 > 0 or d3 > 0))


@njit(cache=True)
def _polygons_intersect_2d(P, na):
    """Closed 2D polygons (rows ``0..na-1`` and ``na..``, each a segment or triangle) share a point."""
    nb = len(P) - na
    for i in range(na if na > 2 else 1):
        for j in range(nb if nb > 2 else 1):
            if _segments_intersect_2d(P, i, (i + 1) % na, na + j, na + (j + 1) % nb):
                return True
    if nb == 3 and _point_in_triangle_2d(P, 0, na, na + 1, na + 2):
        return True
    return na == 3 and _point_in_triangle_2d(P, na, 0, 1, 2)


@njit(cache=True)
def _coplanar_intersect(v, rows, na):
    """``v[rows[:na]]`` and ``v[rows[na:]]`` (segment or triangle each, all coplanar) share a point."""
    base = 0 if na == 3 else na  # project with a triangle's normal
    P = _project(v, rows, rows[base], rows[base + 1], rows[base + 2])
    return _polygons_intersect_2d(P, na)


@njit(cache=True)
def _segment_triangle(v, p, q, a, b, c):
    """Closed segment ``pq`` and closed triangle ``abc`` (rows of ``v``) share a point."""
    op = _orient3d(v, a, b, c, p)
    oq = _orient3d(v, a, b, c, q)
    if (op > 0 and oq > 0) or (op < 0 and oq < 0):
        return False
    if op == 0 and oq == 0:
        return _coplanar_intersect(v, np.array([p, q, a, b, c]), 2)
    # The segment crosses the plane; it hits the triangle if it passes on the same side of all three edges.
    s1 = _orient3d(v, p, q, a, b)
    s2 = _orient3d(v, p, q, b, c)
    s3 = _orient3d(v, p, q, c, a)
    return not ((s1 < 0 or s2 < 0 or s3 < 0) and (s1 > 0 or s2 > 0 or s3 > 0))


@njit(cache=True)
def _alone_first(p, q, r, dp, dq, dr):
    """Devillers and Guigue's branch table: triangle ``pqr`` rotated so that p is alone on its side of the other
    triangle's plane (signed distances dp, dq, dr); ``(p, q, r, mirror, coplanar)``, where ``mirror`` says the other
    triangle must swap its last two corners to keep the orientations compatible, and ``coplanar`` that all three
    distances are zero."""
    mirror = coplanar = False
    if dp > 0.0:
        if dq > 0.0:
            p, q, r, mirror = r, p, q, True
        elif dr > 0.0:
            p, q, r, mirror = q, r, p, True
    elif dp < 0.0:
        if dq < 0.0:
            p, q, r = r, p, q
        elif dr < 0.0:
            p, q, r = q, r, p
        else:
            mirror = True
    elif dq < 0.0:
        if dr >= 0.0:
            p, q, r, mirror = q, r, p, True
    elif dq > 0.0:
        if dr > 0.0:
            mirror = True
        else:
            p, q, r = q, r, p
    elif dr > 0.0:
        p, q, r = r, p, q
    elif dr < 0.0:
        p, q, r, mirror = r, p, q, True
    else:
        coplanar = True
    return p, q, r, mirror, coplanar


@njit(cache=True)
def _triangle_triangle(v, p1, q1, r1, p2, q2, r2):
    """Closed triangles ``p1q1r1`` and ``p2q2r2`` (rows of ``v``) share a point: Devillers and Guigue (2003),
    "Faster triangle-triangle intersection tests", with their reference code's branch tables."""
    dp1 = _orient3d(v, p2, q2, r2, p1)
    dq1 = _orient3d(v, p2, q2, r2, q1)
    dr1 = _orient3d(v, p2, q2, r2, r1)
    if (dp1 > 0.0 and dq1 > 0.0 and dr1 > 0.0) or (dp1 < 0.0 and dq1 < 0.0 and dr1 < 0.0):
        return False
    dp2 = _orient3d(v, p1, q1, r1, p2)
    dq2 = _orient3d(v, p1, q1, r1, q2)
    dr2 = _orient3d(v, p1, q1, r1, r2)
    if (dp2 > 0.0 and dq2 > 0.0 and dr2 > 0.0) or (dp2 < 0.0 and dq2 < 0.0 and dr2 < 0.0):
        return False
    coplanar = np.array([p1, q1, r1, p2, q2, r2])
    # Rotate triangle 1 so that p1 is alone on its side of plane 2; "swap" mirrors triangle 2 to keep the
    # orientations compatible (q2 <-> r2 with their signs).
    p1, q1, r1, swap, coplanar_case = _alone_first(p1, q1, r1, dp1, dq1, dr1)
    if coplanar_case:
        dp2 = dq2 = dr2 = 0.0  # coplanar: fall through to the single coplanar test below
    if swap:
        q2, r2, dq2, dr2 = r2, q2, dr2, dq2
    # Now rotate triangle 2 so that p2 is alone on its side of plane 1; "flip" swaps q1 and r1.
    p2, q2, r2, flip, coplanar_case = _alone_first(p2, q2, r2, dp2, dq2, dr2)
    if coplanar_case:  # one call site: each inlined copy of the 2D test costs seconds of compile
        return _coplanar_intersect(v, coplanar, 3)
    if flip:
        q1, r1 = r1, q1
    # The two triangles' intervals on the planes' common line overlap (the paper's CHECK_MIN_MAX).
    if _orient3d(v, p2, p1, q1, q2) > 0.0:
        return False
    return not _orient3d(v, p2, r1, p1, r2) > 0.0


def triangles_intersect(a: np.ndarray, b: np.ndarray) -> bool:
    """Closed triangles ``a`` and ``b`` (``(3, 3)`` float64 corners, one per row) share a point."""
    v = np.ascontiguousarray(np.concatenate([a, b]), dtype=np.float64)
    return bool(_triangle_triangle(v, 0, 1, 2, 3, 4, 5))


def segment_intersects_triangle(segment: np.ndarray, triangle: np.ndarray) -> bool:
    """Closed segment (``(2, 3)`` float64) and closed triangle (``(3, 3)`` float64) share a point."""
    v = np.ascontiguousarray(np.concatenate([segment, triangle]), dtype=np.float64)
    return bool(_segment_triangle(v, 0, 1, 2, 3, 4))


@njit(cache=True)
def _pair_intersects(v, t, a, b):
    """Triangles ``t[a]`` and ``t[b]`` intersect improperly (see the module docstring for shared corners)."""
    shared = 0
    ia0 = ia1 = ib0 = ib1 = -1
    for i in range(3):
        for j in range(3):
            if t[a, i] == t[b, j]:
                if shared == 0:
                    ia0, ib0 = i, j
                else:
                    ia1, ib1 = i, j
                shared += 1
    if shared == 0:
        return _triangle_triangle(v, t[a, 0], t[a, 1], t[a, 2], t[b, 0], t[b, 1], t[b, 2])
    if shared == 1:
        # Their intersection is convex and contains the shared corner s; if it holds another point, its far end
        # lies on the edge opposite s of one triangle (a corner of it, or a crossing of that edge), so testing each
        # opposite edge against the other triangle is complete. Those edges miss s, so a hit is a true overlap.
        a1, a2 = t[a, (ia0 + 1) % 3], t[a, (ia0 + 2) % 3]
        b1, b2 = t[b, (ib0 + 1) % 3], t[b, (ib0 + 2) % 3]
        s = t[a, ia0]
        for _ in range(2):  # a loop, not two calls: one inlined copy of the segment test
            if _segment_triangle(v, a1, a2, s, b1, b2):
                return True
            a1, a2, b1, b2 = b1, b2, a1, a2
        return False
    if shared == 2:
        # Different planes meet only along the shared edge's line; coplanar ones overlap iff folded onto each other.
        e0, e1 = t[a, ia0], t[a, ia1]
        ca, cb = t[a, 3 - ia0 - ia1], t[b, 3 - ib0 - ib1]
        if _orient3d(v, e0, e1, ca, cb) != 0.0:
            return False
        P = _project(v, np.array([e0, e1, ca, cb]), e0, e1, ca)
        s1 = _orient2d(P, 0, 1, 2)
        s2 = _orient2d(P, 0, 1, 3)
        return (s1 > 0 and s2 > 0) or (s1 < 0 and s2 < 0)
    return True  # the same three vertices: a duplicated face


def _candidate_pairs(lo: np.ndarray, hi: np.ndarray, skip: np.ndarray, cell: float) -> np.ndarray:
    """Broad phase: ``(p, 2) int64`` pairs of triangles whose bounding boxes ``lo``/``hi`` ``(m, 3)`` overlap.

    Boxes go into a uniform grid of cubes of side ``cell`` (numpy: one entry per box and cell it touches); each cell's
    members are then paired in Numba, and a pair is kept only in the cell holding the low corner of the two boxes'
    overlap, so it is reported once.
    """
    origin = lo.min(axis=0)
    dims = ((hi.max(axis=0) - origin) / cell).astype(np.int64) + 1
    first = np.minimum(((lo - origin) / cell).astype(np.int64), dims - 1)
    last = np.minimum(((hi - origin) / cell).astype(np.int64), dims - 1)
    first, last = first[~skip], last[~skip]
    ids = np.flatnonzero(~skip)
    n = last - first + 1
    per = n.prod(axis=1)
    owner = np.repeat(np.arange(len(ids)), per)
    local = np.arange(len(owner)) - np.repeat(np.cumsum(per) - per, per)
    nyz = (n[:, 1] * n[:, 2])[owner]
    x = first[owner, 0] + local // nyz
    y = first[owner, 1] + (local // n[owner, 2]) % n[owner, 1]
    z = first[owner, 2] + local % n[owner, 2]
    key = (x * dims[1] + y) * dims[2] + z
    order = np.argsort(key, kind="stable")
    key, owner = key[order], owner[order]
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1], True])
    cells = np.stack([x[order], y[order], z[order]], axis=1)
    size = np.diff(starts)
    # Preallocate the worst case (every pair in every cell): growing an array inside Numba costs ~20 s of compile.
    out = np.empty((int(np.sum(size * (size - 1) // 2)), 2), np.int64)
    count = _pair_cells(ids[owner], cells, starts, lo, hi, first[owner], out)
    return out[:count]


@njit(cache=True)
def _pair_cells(members, cells, starts, lo, hi, member_first, out):
    # member_first[i]: the lowest cell of member i's box; lo/hi are indexed by triangle id. Returns the pair count.
    count = 0
    for g in range(len(starts) - 1):
        s, e = starts[g], starts[g + 1]
        for i in range(s, e):
            a = members[i]
            for j in range(i + 1, e):
                b = members[j]
                if (lo[b, 0] > hi[a, 0] or lo[a, 0] > hi[b, 0] or lo[b, 1] > hi[a, 1]
                        or lo[a, 1] > hi[b, 1] or lo[b, 2] > hi[a, 2] or lo[a, 2] > hi[b, 2]):
                    continue
                # Report the pair only in the cell of the overlap's low corner: the larger of the two first cells.
                if (max(member_first[i, 0], member_first[j, 0]) != cells[s, 0]
                        or max(member_first[i, 1], member_first[j, 1]) != cells[s, 1]
                        or max(member_first[i, 2], member_first[j, 2]) != cells[s, 2]):
                    continue
                out[count, 0] = min(a, b)
                out[count, 1] = max(a, b)
                count += 1
    return count


@njit(cache=True)
def _narrow_phase(v, t, candidates):
    keep = np.zeros(len(candidates), np.bool_)
    for k in range(len(candidates)):
        keep[k] = _pair_intersects(v, t, candidates[k, 0], candidates[k, 1])
    return keep


def crossing_pairs(surface: SurfaceMesh, skip: np.ndarray) -> np.ndarray:
    """``(k, 2) int64`` triangle pairs ``(i, j)``, ``i < j``, lexicographically sorted, that intersect improperly,
    leaving out the triangles ``skip`` ``(s,) int`` (those whose plane is undefined).

    See the module docstring for what counts for pairs sharing a vertex or an edge.
    """
    t = surface.triangles.astype(np.int64)
    if len(t) < 2:
        return np.zeros((0, 2), np.int64)
    p = surface.vertices[t]
    lo, hi = p.min(axis=1), p.max(axis=1)
    skipped = np.zeros(len(t), np.bool_)
    skipped[np.asarray(skip, dtype=np.int64)] = True
    # Cell side: twice the median box extent keeps most boxes in 1-8 cells and few triangles per cell; never so
    # small that the grid has more than ~8 cells per triangle (one huge triangle among tiny ones).
    extent = np.ptp(surface.vertices, axis=0)
    cell = max(2.0 * float(np.median((hi - lo).max(axis=1))),
               float(np.prod(extent + 1e-300) / (8.0 * len(t))) ** (1.0 / 3.0), 1e-300)
    candidates = _candidate_pairs(lo, hi, skipped, cell)
    pairs = candidates[_narrow_phase(surface.vertices, t, candidates)]
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


