"""Checks that a triangle surface is a valid boundary of a solid: the input contract of the hybrid mesh (§5).

TetGen (§5 step 3) needs a closed, 2-manifold, consistently oriented, self-intersection-free surface, and the FEM
body must be one piece whose faces point outward. Each check is a function that returns the offending items, so the
simplifier and the tests can reuse them; :func:`validate_surface` runs them all and raises one :class:`MeshError`
naming every defect it found, its count, the first indices, and the fix.

Choices where the paper is silent:

* **Degenerate triangle**: a repeated vertex index, or area ``<= DEGENERATE_AREA_RATIO * (longest edge)²`` (the
  three corners are collinear or coincide up to round-off; a small but well-shaped triangle is *not* degenerate).
* **Sliver triangle**: not degenerate, but ``area <= SLIVER_AREA_RATIO * (longest edge)²`` (a corner within 0.2 % of
  the longest edge from the line through it). TetGen, which may not add boundary points (switch ``Y``), cannot fill
  it: measured on the cube, a top-face vertex moved toward its opposite edge makes TetGen fail below a ratio of
  2.7e-4 (a 3 µm sliver on a 7.5 mm edge), and passes above. The bound 1e-3 leaves a margin of about 4; the shared
  organ meshes and the built-in models have no triangle below 5e-3.
* **Self-intersection** (Devillers-Guigue orientation predicates in plain float64, no exact arithmetic):
  triangle pairs sharing no vertex intersect if they share any point (touching counts); pairs sharing one vertex
  intersect if they share any point other than that vertex (tested by the edge opposite the shared vertex of each
  against the other triangle, which is complete: see :func:`_pair_intersects`); pairs sharing an edge
  intersect only if they are coplanar (orientation exactly 0.0) and folded onto each other; pairs with the same
  three vertices (duplicate faces) always intersect. Broad phase: the triangles' bounding boxes in a uniform grid
  (cell side twice the median box size), each overlapping pair tested once, in Numba.
* **Components** are vertex-connected pieces (two tetrahedra sharing one vertex are one component with a
  non-manifold vertex).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import MeshError, first_indices
from .surface import SurfaceMesh

# A triangle whose area is at most this fraction of its longest edge squared has collinear corners up to
# round-off: its normal is noise. (An equilateral triangle has ratio 0.43.)
DEGENERATE_AREA_RATIO = 1e-12
# A triangle below this area / (longest edge)² is a sliver TetGen cannot fill without boundary points (see above).
SLIVER_AREA_RATIO = 1e-3

# How each defect can be fixed; quoted in the error messages.
_FIX_REPAIR = "repair (read_surface(..., repair=True), repair_surface(surface), or --repair on the command line) fixes it"
_FIX_MANUAL = "fix the mesh in MeshLab or Blender"


# ---------------------------------------------------------------------------------------------------------------
# Topological checks
# ---------------------------------------------------------------------------------------------------------------


def _edge_faces(triangles: np.ndarray):
    """Undirected edges with their face counts: ``(edges (k, 2) int64 sorted rows, counts (k,))``."""
    directed = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64)
    low, high = directed.min(axis=1), directed.max(axis=1)
    base = int(high.max()) + 1 if len(high) else 1
    # One int64 key per edge: np.unique on a 1D array is ~20x faster than on rows (axis=0).
    keys, counts = np.unique(low * base + high, return_counts=True)
    return np.stack([keys // base, keys % base], axis=1), counts


def repeated_index_triangles(surface: SurfaceMesh) -> np.ndarray:
    """``(k,) int64`` triangles that name the same vertex twice (e.g. ``(4, 4, 9)``)."""
    t = surface.triangles
    return np.flatnonzero((t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 2] == t[:, 0]))


def degenerate_triangles(surface: SurfaceMesh, *, area_ratio: float = DEGENERATE_AREA_RATIO) -> np.ndarray:
    """``(k,) int64`` sorted triangles with a repeated vertex index or (near-)zero area.

    A triangle is degenerate when ``area <= area_ratio * longest_edge²`` (collinear or coincident corners).
    """
    p = surface.vertices[surface.triangles]
    longest2 = np.max(np.stack([np.sum((p[:, 1] - p[:, 0]) ** 2, axis=1),
                                np.sum((p[:, 2] - p[:, 1]) ** 2, axis=1),
                                np.sum((p[:, 0] - p[:, 2]) ** 2, axis=1)], axis=1), axis=1)
    flat = np.flatnonzero(surface.triangle_areas <= area_ratio * longest2)
    return np.union1d(flat, repeated_index_triangles(surface))


def sliver_triangles(surface: SurfaceMesh) -> np.ndarray:
    """``(k,) int64`` sorted triangles that are slivers but not degenerate (see :data:`SLIVER_AREA_RATIO`)."""
    slivers = degenerate_triangles(surface, area_ratio=SLIVER_AREA_RATIO)
    return np.setdiff1d(slivers, degenerate_triangles(surface))


def boundary_edges(surface: SurfaceMesh) -> np.ndarray:
    """``(k, 2) int64`` undirected edges (sorted rows) used by exactly one triangle: the holes' rims."""
    edges, counts = _edge_faces(surface.triangles)
    return edges[counts == 1]


def nonmanifold_edges(surface: SurfaceMesh) -> np.ndarray:
    """``(k, 2) int64`` undirected edges (sorted rows) shared by more than two triangles."""
    edges, counts = _edge_faces(surface.triangles)
    return edges[counts > 2]


def nonmanifold_vertices(surface: SurfaceMesh) -> np.ndarray:
    """``(k,) int64`` sorted vertices whose triangle fan is not a single disc (several fans meet at the vertex).

    Each triangle corner ``(t, v)`` is a node; two corners at the same vertex ``v`` are linked when their
    triangles share an edge ``(v, w)``. A vertex whose corners fall into more than one linked group is
    non-manifold (e.g. two tetrahedra touching at one vertex, or an hourglass).
    """
    t = surface.triangles.astype(np.int64)
    m = len(t)
    if m == 0:
        return np.zeros(0, np.int64)
    corner_vertex = t.ravel()  # corner c = 3 * triangle + local index
    corner = np.arange(3 * m)
    local = corner % 3
    # Every corner sees its two fan edges (v, next) and (v, prev); corners with the same (v, w) are adjacent.
    nxt = t[corner // 3, (local + 1) % 3]
    prv = t[corner // 3, (local + 2) % 3]
    v = np.concatenate([corner_vertex, corner_vertex])
    w = np.concatenate([nxt, prv])
    c = np.concatenate([corner, corner])
    order = np.lexsort((w, v))
    v, w, c = v[order], w[order], c[order]
    same = (v[1:] == v[:-1]) & (w[1:] == w[:-1])
    graph = coo_matrix((np.ones(same.sum()), (c[:-1][same], c[1:][same])), shape=(3 * m, 3 * m))
    _, label = connected_components(graph, directed=False)
    # Count distinct fan labels per vertex (one int64 key per (vertex, fan) pair).
    pairs = np.unique(corner_vertex * (3 * m) + label)
    vertices, fans = np.unique(pairs // (3 * m), return_counts=True)
    return vertices[fans > 1]


def component_labels(surface: SurfaceMesh) -> tuple[int, np.ndarray]:
    """Vertex-connected components: ``(count, labels)`` with ``labels (m,) int32`` per triangle.

    Labels are ordered by decreasing component size (label 0 is the largest piece).
    """
    t = surface.triangles
    n = surface.vertex_count
    if len(t) == 0:
        return 0, np.zeros(0, np.int32)
    rows = np.concatenate([t[:, 0], t[:, 1]])
    cols = np.concatenate([t[:, 1], t[:, 2]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, vertex_label = connected_components(graph, directed=False)
    raw = vertex_label[t[:, 0]]
    used, inverse, sizes = np.unique(raw, return_inverse=True, return_counts=True)
    rank = np.empty(len(used), np.int32)
    rank[np.argsort(-sizes, kind="stable")] = np.arange(len(used), dtype=np.int32)
    return len(used), rank[inverse.ravel()]


def inconsistent_edges(surface: SurfaceMesh) -> np.ndarray:
    """``(k, 2) int64`` undirected edges (sorted rows) that two triangles traverse in the same direction.

    On a consistently oriented manifold each interior edge is walked once as ``(a, b)`` and once as ``(b, a)``.
    """
    directed = surface.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64)
    directed = directed[directed[:, 0] != directed[:, 1]]
    base = surface.vertex_count
    keys, counts = np.unique(directed[:, 0] * base + directed[:, 1], return_counts=True)
    twice = keys[counts > 1]
    a, b = twice // base, twice % base
    low, high = np.minimum(a, b), np.maximum(a, b)
    return np.unique(np.stack([low, high], axis=1), axis=0).reshape(-1, 2)


def faces_inward(surface: SurfaceMesh) -> bool:
    """True when the enclosed signed volume is negative, i.e. the (consistently oriented) faces point inward."""
    return surface.signed_volume < 0.0


# ---------------------------------------------------------------------------------------------------------------
# Self-intersections (Numba)
# ---------------------------------------------------------------------------------------------------------------


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
    swap = False
    if dp1 > 0.0:
        if dq1 > 0.0:
            p1, q1, r1, swap = r1, p1, q1, True
        elif dr1 > 0.0:
            p1, q1, r1, swap = q1, r1, p1, True
    elif dp1 < 0.0:
        if dq1 < 0.0:
            p1, q1, r1 = r1, p1, q1
        elif dr1 < 0.0:
            p1, q1, r1 = q1, r1, p1
        else:
            swap = True
    elif dq1 < 0.0:
        if dr1 >= 0.0:
            p1, q1, r1, swap = q1, r1, p1, True
    elif dq1 > 0.0:
        if dr1 > 0.0:
            swap = True
        else:
            p1, q1, r1 = q1, r1, p1
    elif dr1 > 0.0:
        p1, q1, r1 = r1, p1, q1
    elif dr1 < 0.0:
        p1, q1, r1, swap = r1, p1, q1, True
    else:
        dp2 = dq2 = dr2 = 0.0  # coplanar: fall through to the single coplanar test below
    if swap:
        q2, r2, dq2, dr2 = r2, q2, dr2, dq2
    # Now rotate triangle 2 so that p2 is alone on its side of plane 1; "flip" swaps q1 and r1.
    flip = coplanar_case = False
    if dp2 > 0.0:
        if dq2 > 0.0:
            p2, q2, r2, flip = r2, p2, q2, True
        elif dr2 > 0.0:
            p2, q2, r2, flip = q2, r2, p2, True
    elif dp2 < 0.0:
        if dq2 < 0.0:
            p2, q2, r2 = r2, p2, q2
        elif dr2 < 0.0:
            p2, q2, r2 = q2, r2, p2
        else:
            flip = True
    elif dq2 < 0.0:
        if dr2 >= 0.0:
            p2, q2, r2, flip = q2, r2, p2, True
    elif dq2 > 0.0:
        if dr2 > 0.0:
            flip = True
        else:
            p2, q2, r2 = q2, r2, p2
    elif dr2 > 0.0:
        p2, q2, r2 = r2, p2, q2
    elif dr2 < 0.0:
        p2, q2, r2, flip = r2, p2, q2, True
    else:
        coplanar_case = True
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


def self_intersections(surface: SurfaceMesh) -> np.ndarray:
    """``(k, 2) int64`` triangle pairs ``(i, j)``, ``i < j``, lexicographically sorted, that intersect improperly.

    See the module docstring for what counts for pairs sharing a vertex or an edge. Degenerate triangles are skipped
    (their planes are undefined; :func:`degenerate_triangles` reports them).
    """
    t = surface.triangles.astype(np.int64)
    if len(t) < 2:
        return np.zeros((0, 2), np.int64)
    p = surface.vertices[t]
    lo, hi = p.min(axis=1), p.max(axis=1)
    skip = np.zeros(len(t), np.bool_)
    skip[degenerate_triangles(surface)] = True
    # Cell side: twice the median box extent keeps most boxes in 1-8 cells and few triangles per cell; never so
    # small that the grid has more than ~8 cells per triangle (one huge triangle among tiny ones).
    extent = np.ptp(surface.vertices, axis=0)
    cell = max(2.0 * float(np.median((hi - lo).max(axis=1))),
               float(np.prod(extent + 1e-300) / (8.0 * len(t))) ** (1.0 / 3.0), 1e-300)
    candidates = _candidate_pairs(lo, hi, skip, cell)
    pairs = candidates[_narrow_phase(surface.vertices, t, candidates)]
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


# ---------------------------------------------------------------------------------------------------------------
# The whole contract
# ---------------------------------------------------------------------------------------------------------------


def _smallest_height(surface: SurfaceMesh, triangles: np.ndarray) -> float:
    """Smallest height [m] (twice the area over the longest edge) of the first of ``triangles``."""
    p = surface.vertices[surface.triangles[triangles[0]]]
    longest = max(np.linalg.norm(p[1] - p[0]), np.linalg.norm(p[2] - p[1]), np.linalg.norm(p[0] - p[2]))
    return float(2.0 * surface.triangle_areas[triangles[0]] / longest)


def _pairs(rows: np.ndarray, limit: int = 3) -> str:
    shown = ", ".join(f"({int(a)}, {int(b)})" for a, b in rows[:limit])
    return shown + (f", ... ({len(rows) - limit} more)" if len(rows) > limit else "")


def surface_defects(surface: SurfaceMesh) -> list[str]:
    """Every defect that keeps ``surface`` from bounding a solid, one human-readable line each (empty if valid).

    Each line names the defect, its count, the first indices, and the fix.
    """
    if surface.triangle_count == 0:
        return ["the surface has no triangles; read a mesh with triangle faces"]
    defects = []
    degenerate = degenerate_triangles(surface)
    if degenerate.size:
        defects.append(
            f"{degenerate.size} degenerate triangles (repeated vertex or zero area; first: "
            f"{first_indices(degenerate)}); {_FIX_REPAIR} where removing them keeps the surface closed, "
            f"otherwise {_FIX_MANUAL}")
    slivers = sliver_triangles(surface)
    if slivers.size:
        shortest = _smallest_height(surface, slivers)
        defects.append(
            f"{slivers.size} sliver triangles too thin to tetrahedralize (a corner nearly on the opposite edge; "
            f"first: {first_indices(slivers)}, triangle {int(slivers[0])} is {shortest:.3g} m thin); remesh them "
            f"(e.g. MeshLab 'Isotropic Explicit Remeshing') or move that corner away from the edge")
    holes = boundary_edges(surface)
    if len(holes):
        defects.append(
            f"the surface is not closed: {len(holes)} boundary edges (first: {_pairs(holes)}); close the holes, "
            f"e.g. MeshLab 'Close Holes' or pymeshfix")
    fans = nonmanifold_edges(surface)
    if len(fans):
        defects.append(
            f"{len(fans)} non-manifold edges shared by more than two triangles (first: {_pairs(fans)}); "
            f"{_FIX_MANUAL}")
    pinches = nonmanifold_vertices(surface)
    if pinches.size:
        defects.append(
            f"{pinches.size} non-manifold vertices where several triangle fans meet (first: "
            f"{first_indices(pinches)}); split them or {_FIX_MANUAL}")
    count, labels = component_labels(surface)
    if count > 1:
        sizes = np.bincount(labels)
        firsts = [int(np.flatnonzero(labels == k)[0]) for k in range(1, count)]
        defects.append(
            f"{count} connected components (triangle counts {first_indices(sizes)}; first triangles of the "
            f"smaller ones: {first_indices(firsts)}); keep one body per mesh")
    flipped = inconsistent_edges(surface)
    if len(flipped):
        defects.append(
            f"inconsistent orientation: {len(flipped)} edges walked the same way by both triangles (first: "
            f"{_pairs(flipped)}); {_FIX_REPAIR} by reorienting")
    elif not len(holes) and faces_inward(surface):
        defects.append(
            f"the faces point inward (signed volume {surface.signed_volume:.4g} m³ < 0); {_FIX_REPAIR} by "
            f"reversing every triangle")
    crossings = self_intersections(surface)
    if len(crossings):
        defects.append(
            f"{len(crossings)} self-intersecting triangle pairs (first: {_pairs(crossings)}); "
            f"repair (repair=True, or --repair on the command line) removes them with pymeshfix, or {_FIX_MANUAL}")
    return defects


def validate_surface(surface: SurfaceMesh) -> None:
    """Raise :class:`MeshError` naming every defect of ``surface`` (see :func:`surface_defects`); else return."""
    defects = surface_defects(surface)
    if defects:
        raise MeshError("invalid surface: " + "; ".join(defects))
