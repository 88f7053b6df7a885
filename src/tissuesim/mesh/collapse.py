"""The safety checks of one half-edge collapse in the simplification of M_S (:mod:`.simplify`), as Numba kernels.

A collapse i -> j is refused (:func:`_check_collapse`) when it would break the link condition, raise a vertex's
degree past the kernel's capacity, make a degenerate triangle, turn a triangle's normal too far, fold two adjacent
triangles, or make the surface intersect itself near the changed triangles (segment/triangle tests against every
triangle whose bounding box can reach, found through a uniform grid of vertices). The reasons are
:data:`.simplify.REJECT_REASONS`, in order.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _v(P, i):
    return (P[i, 0], P[i, 1], P[i, 2])


@njit(cache=True)
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(cache=True)
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def _tri_normal(P, a, b, c):
    """Unnormalised normal (twice the area vector) of triangle (a, b, c)."""
    pa = _v(P, a)
    return _cross(_sub(_v(P, b), pa), _sub(_v(P, c), pa))


@njit(cache=True)
def _quality(P, a, b, c):
    """4 sqrt(3) area / sum of squared edge lengths: 1 for equilateral, 0 for degenerate."""
    n = _tri_normal(P, a, b, c)
    area = 0.5 * np.sqrt(_dot(n, n))
    pa, pb, pc = _v(P, a), _v(P, b), _v(P, c)
    e0, e1, e2 = _sub(pb, pa), _sub(pc, pb), _sub(pa, pc)
    s = _dot(e0, e0) + _dot(e1, e1) + _dot(e2, e2)
    if s <= 0.0:
        return 0.0
    return 4.0 * np.sqrt(3.0) * area / s


@njit(cache=True)
def _segment_hits_triangle(p, q, a, b, c):
    """Does segment pq meet triangle abc (touching counts; coplanar pairs do not: flips catch those)?"""
    n = _cross(_sub(b, a), _sub(c, a))
    nn = np.sqrt(_dot(n, n))
    if nn == 0.0:
        return False
    dp = _dot(n, _sub(p, a)) / nn
    dq = _dot(n, _sub(q, a)) / nn
    pq = _sub(q, p)
    tol = 1e-9 * (np.sqrt(_dot(pq, pq)) + np.sqrt(nn))
    if (dp > tol and dq > tol) or (dp < -tol and dq < -tol):
        return False
    if abs(dp) <= tol and abs(dq) <= tol:
        return False
    s = dp / (dp - dq) if dp != dq else 0.0
    x = (p[0] + s * pq[0], p[1] + s * pq[1], p[2] + s * pq[2])
    atol = -1e-9 * nn * nn
    if _dot(_cross(_sub(b, a), _sub(x, a)), n) < atol:
        return False
    if _dot(_cross(_sub(c, b), _sub(x, b)), n) < atol:
        return False
    if _dot(_cross(_sub(a, c), _sub(x, c)), n) < atol:
        return False
    return True


@njit(cache=True)
def _triangles_intersect(P, t, s):
    """Do triangles t and s (vertex triples) intersect other than along shared vertices or a shared edge?"""
    shared = 0
    for u in range(3):
        for v in range(3):
            if t[u] == s[v]:
                shared += 1
    if shared >= 3:
        return True              # a duplicate triangle: never acceptable
    if shared == 2:
        return False             # edge neighbours: the fold test handles them
    if shared == 1:
        # Only the edge opposite the shared vertex can cross the other triangle.
        for u in range(3):
            in_s = t[u] == s[0] or t[u] == s[1] or t[u] == s[2]
            if in_s:
                if _segment_hits_triangle(_v(P, t[(u + 1) % 3]), _v(P, t[(u + 2) % 3]), _v(P, s[0]), _v(P, s[1]),
                                          _v(P, s[2])):
                    return True
        for v in range(3):
            in_t = s[v] == t[0] or s[v] == t[1] or s[v] == t[2]
            if in_t:
                if _segment_hits_triangle(_v(P, s[(v + 1) % 3]), _v(P, s[(v + 2) % 3]), _v(P, t[0]), _v(P, t[1]),
                                          _v(P, t[2])):
                    return True
        return False
    for u in range(3):
        if _segment_hits_triangle(_v(P, t[u]), _v(P, t[(u + 1) % 3]), _v(P, s[0]), _v(P, s[1]), _v(P, s[2])):
            return True
        if _segment_hits_triangle(_v(P, s[u]), _v(P, s[(u + 1) % 3]), _v(P, t[0]), _v(P, t[1]), _v(P, t[2])):
            return True
    return False


@njit(cache=True)
def _after(T, t, i, j):
    """Triangle t's vertices after the collapse i -> j."""
    a, b, c = T[t, 0], T[t, 1], T[t, 2]
    return (j if a == i else a, j if b == i else b, j if c == i else c)


@njit(cache=True)
def _neighbours(T, vt, vt_n, v, out):
    """Fill ``out`` with v's distinct neighbours; return their count."""
    count = 0
    for k in range(vt_n[v]):
        t = vt[v, k]
        for u in range(3):
            w = T[t, u]
            if w == v:
                continue
            seen = False
            for m in range(count):
                if out[m] == w:
                    seen = True
                    break
            if not seen:
                out[count] = w
                count += 1
    return count


@njit(cache=True)
def _check_collapse(P, T, vt, vt_n, reach, i, j, cos_normal, cos_fold, min_quality, cap, lmax,
                    cell, origin, dims, cell_start, cell_vertices, stamp, stamp_counter, nb_i, nb_j):
    """0 if the collapse i -> j is allowed, else 1 + index of the reason in REJECT_REASONS."""
    # Link condition: on a closed manifold, i and j may share only the two vertices opposite their edge.
    ni = _neighbours(T, vt, vt_n, i, nb_i)
    nj = _neighbours(T, vt, vt_n, j, nb_j)
    common = 0
    for a in range(ni):
        for b in range(nj):
            if nb_i[a] == nb_j[b]:
                common += 1
    if common != 2:
        return 1
    if vt_n[j] + vt_n[i] - 4 > cap:
        return 2
    # Changed triangles: those of i not containing j, with i replaced by j.
    for k in range(vt_n[i]):
        t = vt[i, k]
        if T[t, 0] == j or T[t, 1] == j or T[t, 2] == j:
            continue
        new = _after(T, t, i, j)
        if _quality(P, new[0], new[1], new[2]) < min_quality:
            return 3
        n_old = _tri_normal(P, T[t, 0], T[t, 1], T[t, 2])
        n_new = _tri_normal(P, new[0], new[1], new[2])
        if _dot(n_old, n_new) < cos_normal * np.sqrt(_dot(n_old, n_old) * _dot(n_new, n_new)):
            return 4
    # Folds across the edges of the changed triangles.
    for k in range(vt_n[i]):
        t = vt[i, k]
        if T[t, 0] == j or T[t, 1] == j or T[t, 2] == j:
            continue
        new = _after(T, t, i, j)
        n_new = _tri_normal(P, new[0], new[1], new[2])
        for e in range(3):
            u, w = new[e], new[(e + 1) % 3]
            # the other triangle across (u, w) after the collapse: look among triangles of u (and i when u == j)
            for pass_ in range(2):
                src = u if pass_ == 0 else i
                if pass_ == 1 and u != j:
                    break
                for m in range(vt_n[src]):
                    s = vt[src, m]
                    if s == t:
                        continue
                    has_i = T[s, 0] == i or T[s, 1] == i or T[s, 2] == i
                    has_j = T[s, 0] == j or T[s, 1] == j or T[s, 2] == j
                    if has_i and has_j:
                        continue
                    other = _after(T, s, i, j)
                    if (other[0] == w or other[1] == w or other[2] == w) and \
                            (other[0] == u or other[1] == u or other[2] == u):
                        n_s = _tri_normal(P, other[0], other[1], other[2])
                        if _dot(n_new, n_s) < cos_fold * np.sqrt(_dot(n_new, n_new) * _dot(n_s, n_s)):
                            return 5
    # Self-intersection against every triangle that can reach a changed one: a triangle overlapping the changed
    # triangle's bounding box B has a vertex v within reach[v] (its longest edge) of B, and reach <= lmax.
    for k in range(vt_n[i]):
        t = vt[i, k]
        if T[t, 0] == j or T[t, 1] == j or T[t, 2] == j:
            continue
        new = _after(T, t, i, j)
        stamp_counter[0] += 1
        mark = stamp_counter[0]
        b0 = _bbox(P, new)
        lo0 = _cell_index(b0[0][0] - lmax, origin[0], cell, dims[0])
        hi0 = _cell_index(b0[1][0] + lmax, origin[0], cell, dims[0])
        lo1 = _cell_index(b0[0][1] - lmax, origin[1], cell, dims[1])
        hi1 = _cell_index(b0[1][1] + lmax, origin[1], cell, dims[1])
        lo2 = _cell_index(b0[0][2] - lmax, origin[2], cell, dims[2])
        hi2 = _cell_index(b0[1][2] + lmax, origin[2], cell, dims[2])
        for cx in range(lo0, hi0 + 1):
            for cy in range(lo1, hi1 + 1):
                for cz in range(lo2, hi2 + 1):
                    c = (cx * dims[1] + cy) * dims[2] + cz
                    for q in range(cell_start[c], cell_start[c + 1]):
                        v = cell_vertices[q]
                        if vt_n[v] == 0:
                            continue
                        r = reach[v]
                        if (P[v, 0] < b0[0][0] - r or P[v, 0] > b0[1][0] + r or P[v, 1] < b0[0][1] - r
                                or P[v, 1] > b0[1][1] + r or P[v, 2] < b0[0][2] - r or P[v, 2] > b0[1][2] + r):
                            continue
                        for m in range(vt_n[v]):
                            s = vt[v, m]
                            if stamp[s] == mark or s == t:
                                continue
                            stamp[s] = mark
                            has_i = T[s, 0] == i or T[s, 1] == i or T[s, 2] == i
                            has_j = T[s, 0] == j or T[s, 1] == j or T[s, 2] == j
                            if has_i and has_j:
                                continue
                            other = _after(T, s, i, j)
                            b1 = _bbox(P, other)
                            if (b1[0][0] > b0[1][0] or b1[1][0] < b0[0][0] or b1[0][1] > b0[1][1]
                                    or b1[1][1] < b0[0][1] or b1[0][2] > b0[1][2] or b1[1][2] < b0[0][2]):
                                continue
                            if _triangles_intersect(P, new, other):
                                return 6
    return 0


@njit(cache=True)
def _bbox(P, tri):
    lo = (min(P[tri[0], 0], P[tri[1], 0], P[tri[2], 0]), min(P[tri[0], 1], P[tri[1], 1], P[tri[2], 1]),
          min(P[tri[0], 2], P[tri[1], 2], P[tri[2], 2]))
    hi = (max(P[tri[0], 0], P[tri[1], 0], P[tri[2], 0]), max(P[tri[0], 1], P[tri[1], 1], P[tri[2], 1]),
          max(P[tri[0], 2], P[tri[1], 2], P[tri[2], 2]))
    return lo, hi


@njit(cache=True)
def _cell_index(x, origin, cell, dim):
    return max(0, min(dim - 1, int(np.floor((x - origin) / cell))))
