"""The hybrid mesh's maps (§5, §6.1): each M_S vertex's closest point on the coarse surface M'_S (the triangle and
barycentric weights that carry its load to the control nodes) and its embedding in a tet of M_V.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..errors import MeshError
from .surface import SurfaceMesh
from .tetmesh import TET_FACES, TetMesh

# Candidates per query in the k-d tree searches; exactness is restored by a second, radius-bounded pass.
NEAREST_CANDIDATES = 16


def closest_on_surface(surface: SurfaceMesh, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each of ``points`` ``(n, 3)`` [m], the closest point on ``surface``.

    Returns:
        ``(triangle (n,) int32, barycentric (n, 3) float64)``: weights in [0, 1] summing to 1.

    Exact: a first pass over the ``NEAREST_CANDIDATES`` nearest triangle centroids bounds the distance d; a second
    pass checks every triangle whose centroid lies within d + (largest centroid-to-corner distance).

    Raises:
        MeshError: coordinates so large that squared distances overflow float64 (the search would be meaningless).
    """
    from scipy.spatial import cKDTree

    p = surface.vertices[surface.triangles]
    centroids = p.mean(axis=1)
    with np.errstate(over="ignore", invalid="ignore"):
        reach = float(np.linalg.norm(p - centroids[:, None, :], axis=2).max())
    tree = cKDTree(centroids)
    k = min(NEAREST_CANDIDATES, surface.triangle_count)
    distance, near = tree.query(points, k=k)
    # an overflowing distance makes the tree answer "no neighbour" (index = count), which the kernel must never see
    if not (np.isfinite(reach) and np.all(np.isfinite(distance))):
        raise MeshError("closest-point search: coordinates too large to measure distances in float64 (a surface "
                        f"{reach:.3g} m from centroid to corner, or points that far); give positions in metres")
    near = np.asarray(near, dtype=np.int64).reshape(len(points), k)
    starts = np.arange(0, len(points) * k + 1, k, dtype=np.int64)
    tri, bary, dist = _closest_kernel(surface.vertices, surface.triangles, points, starts, near.ravel())
    balls = tree.query_ball_point(points, dist + reach + 1e-12)
    counts = np.array([len(b) for b in balls], dtype=np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)])
    flat = np.fromiter((t for b in balls for t in b), dtype=np.int64, count=int(starts[-1]))
    tri, bary, _ = _closest_kernel(surface.vertices, surface.triangles, points, starts, flat)
    return tri.astype(np.int32), bary


def closest_among(vertices: np.ndarray, triangles: np.ndarray, points: np.ndarray,
                  rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each of ``points`` ``(k, 3)`` [m], the closest point on the triangles ``rows`` of
    ``(vertices, triangles)``: ``(row (k,) int64, barycentric (k, 3), distance (k,) [m])``; row −1 and distance inf
    when ``rows`` is empty. O(k × len(rows)), for a caller that knows where to look (:func:`closest_on_surface`
    searches a whole surface)."""
    rows = np.asarray(rows, dtype=np.int64)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    starts = np.arange(len(points) + 1, dtype=np.int64) * rows.size
    return _closest_kernel(vertices, triangles, points, starts, np.tile(rows, len(points)))


def embed_in_volume(volume: TetMesh, points: np.ndarray, coarse: SurfaceMesh, coarse_triangle: np.ndarray,
                    coarse_barycentric: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Barycentric embedding of ``points`` ``(n, 3)`` [m] in ``volume`` (whose boundary is ``coarse``).

    A point inside the volume gets its containing tet (coordinates all >= -1e-9); a point outside gets the tet owning
    the boundary face of its closest point (``coarse_triangle``, ``coarse_barycentric`` from
    :func:`closest_on_surface`), the nearest tet. Coordinates are unclamped, so ``sum(w_k x_k)`` reproduces the point.

    Returns:
        ``(tet (n,) int32, barycentric (n, 4) float64)``.
    """
    from scipy.spatial import cKDTree

    centroids = volume.points[volume.tets].mean(axis=1)
    k = min(2 * NEAREST_CANDIDATES, volume.element_count)
    _, near = cKDTree(centroids).query(points, k=k)
    near = np.asarray(near, dtype=np.int64).reshape(len(points), k)
    tet, bary, found = _containing_kernel(volume.points, volume.tets, points, near)
    # A point on the outer side of the face of its closest point is outside M_V. The others not resolved among the
    # nearest centroids (rare: a huge tet far away) are checked against every tet.
    q = np.einsum("ij,ijk->ik", coarse_barycentric, coarse.vertices[coarse.triangles[coarse_triangle]])
    outer = np.einsum("ij,ij->i", points - q, coarse.triangle_normals[coarse_triangle]) > 0.0
    for i in np.flatnonzero(~found & ~outer):
        w = _barycentric_all(volume.points, volume.tets, points[i])
        best = int(np.argmax(w.min(axis=1)))
        if w[best].min() >= -1e-9:
            tet[i], bary[i], found[i] = best, w[best], True
    # Outside points keep the candidate tet with the largest minimum coordinate (the least extrapolation); the
    # owner of the closest boundary face is the fallback when that is worse (it can be a flat tet near the face).
    outside = np.flatnonzero(~found)
    if outside.size:
        owner = _boundary_face_owner(volume, coarse.triangles)[coarse_triangle[outside]]
        owner_bary = _barycentric_all_rows(volume.points, volume.tets[owner], points[outside])
        better = owner_bary.min(axis=1) > bary[outside].min(axis=1)
        tet[outside[better]] = owner[better]
        bary[outside[better]] = owner_bary[better]
    return tet.astype(np.int32), bary


def own_corner(coarse: SurfaceMesh, count: int) -> tuple[np.ndarray, np.ndarray]:
    """For each coarse vertex 0..count-1, one triangle containing it and weight 1 on that corner."""
    flat = coarse.triangles.ravel()
    first = np.full(count, -1, dtype=np.int64)
    positions = np.arange(len(flat))[::-1]
    first[flat[::-1]] = positions          # last write wins: the first occurrence
    triangle = (first // 3).astype(np.int32)
    bary = np.zeros((count, 3))
    bary[np.arange(count), first % 3] = 1.0
    return triangle, bary


def _boundary_face_owner(volume: TetMesh, triangles: np.ndarray) -> np.ndarray:
    """``(t,) int64`` the tet owning each boundary triangle (vertex indices in M_V numbering)."""
    faces = np.sort(volume.tets[:, TET_FACES].reshape(-1, 3), axis=1).astype(np.int64)
    n = int(volume.node_count)
    keys = (faces[:, 0] * n + faces[:, 1]) * n + faces[:, 2]
    order = np.argsort(keys, kind="stable")
    wanted = np.sort(triangles, axis=1).astype(np.int64)
    wanted_keys = (wanted[:, 0] * n + wanted[:, 1]) * n + wanted[:, 2]
    where = np.searchsorted(keys[order], wanted_keys)
    where = np.minimum(where, len(keys) - 1)
    hit = order[where]
    if not np.array_equal(keys[hit], wanted_keys):
        raise MeshError("some coarse surface triangles are not faces of the coarse volume; rebuild the hybrid mesh")
    return hit // 4


def _barycentric_all(points: np.ndarray, tets: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``(m, 4)`` barycentric coordinates of one point ``x`` in every tet."""
    return _barycentric_all_rows(points, tets, np.broadcast_to(x, (len(tets), 3)))


def _barycentric_all_rows(points: np.ndarray, tets: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``(r, 4)`` barycentric coordinates of ``x[r]`` in ``tets[r]`` (unclamped)."""
    p = points[tets]
    a = np.transpose(p[:, 1:] - p[:, :1], (0, 2, 1))          # columns p1-p0, p2-p0, p3-p0
    w = np.linalg.solve(a, (x - p[:, 0])[..., None])[..., 0]
    return np.concatenate([1.0 - w.sum(axis=1, keepdims=True), w], axis=1)


@njit(cache=True)
def _closest_point_triangle(px, py, pz, P, a, b, c):
    """Closest point of triangle (a, b, c) to p (Ericson, Real-Time Collision Detection §5.1.5): weights, dist²."""
    ax, ay, az = P[a, 0], P[a, 1], P[a, 2]
    abx, aby, abz = P[b, 0] - ax, P[b, 1] - ay, P[b, 2] - az
    acx, acy, acz = P[c, 0] - ax, P[c, 1] - ay, P[c, 2] - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        u, v, w = 1.0, 0.0, 0.0
    else:
        bpx, bpy, bpz = px - P[b, 0], py - P[b, 1], pz - P[b, 2]
        d3 = abx * bpx + aby * bpy + abz * bpz
        d4 = acx * bpx + acy * bpy + acz * bpz
        cpx, cpy, cpz = px - P[c, 0], py - P[c, 1], pz - P[c, 2]
        d5 = abx * cpx + aby * cpy + abz * cpz
        d6 = acx * cpx + acy * cpy + acz * cpz
        vc = d1 * d4 - d3 * d2
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        if d3 >= 0.0 and d4 <= d3:
            u, v, w = 0.0, 1.0, 0.0
        elif d6 >= 0.0 and d5 <= d6:
            u, v, w = 0.0, 0.0, 1.0
        elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
            t = d1 / (d1 - d3)
            u, v, w = 1.0 - t, t, 0.0
        elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
            t = d2 / (d2 - d6)
            u, v, w = 1.0 - t, 0.0, t
        elif va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
            t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            u, v, w = 0.0, 1.0 - t, t
        else:
            denom = 1.0 / (va + vb + vc)
            v = vb * denom
            w = vc * denom
            u = max(0.0, 1.0 - v - w)       # round-off must not make a weight negative
            total = u + v + w
            u, v, w = u / total, v / total, w / total
    qx = u * ax + v * P[b, 0] + w * P[c, 0]
    qy = u * ay + v * P[b, 1] + w * P[c, 1]
    qz = u * az + v * P[b, 2] + w * P[c, 2]
    return u, v, w, (qx - px) ** 2 + (qy - py) ** 2 + (qz - pz) ** 2


@njit(cache=True)
def _closest_kernel(P, T, X, starts, candidates):
    n = X.shape[0]
    tri = np.full(n, -1, dtype=np.int64)
    bary = np.zeros((n, 3))
    dist = np.full(n, np.inf)
    for i in range(n):
        best = np.inf
        for q in range(starts[i], starts[i + 1]):
            t = candidates[q]
            u, v, w, d2 = _closest_point_triangle(X[i, 0], X[i, 1], X[i, 2], P, T[t, 0], T[t, 1], T[t, 2])
            if d2 < best or (d2 == best and t < tri[i]):
                best = d2
                tri[i] = t
                bary[i, 0], bary[i, 1], bary[i, 2] = u, v, w
        dist[i] = np.sqrt(best)
    return tri, bary, dist


@njit(cache=True)
def _containing_kernel(P, tets, X, near):
    """Among each point's candidate tets, the one containing it (largest minimum coordinate >= -1e-9)."""
    n, k = near.shape
    tet = np.full(n, -1, dtype=np.int64)
    bary = np.zeros((n, 4))
    found = np.zeros(n, dtype=np.bool_)
    w = np.zeros(4)
    for i in range(n):
        best = -np.inf
        for q in range(k):
            t = near[i, q]
            a, b, c, d = tets[t, 0], tets[t, 1], tets[t, 2], tets[t, 3]
            m = np.empty((3, 3))
            for r in range(3):
                m[r, 0] = P[b, r] - P[a, r]
                m[r, 1] = P[c, r] - P[a, r]
                m[r, 2] = P[d, r] - P[a, r]
            rhs = np.array([X[i, 0] - P[a, 0], X[i, 1] - P[a, 1], X[i, 2] - P[a, 2]])
            s = np.linalg.solve(m, rhs)
            w[0], w[1], w[2], w[3] = 1.0 - s[0] - s[1] - s[2], s[0], s[1], s[2]
            low = min(w[0], w[1], w[2], w[3])
            if low > best:
                best = low
                tet[i] = t
                bary[i, :] = w
        found[i] = best >= -1e-9
    return tet, bary, found
