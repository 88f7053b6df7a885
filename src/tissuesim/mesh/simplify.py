"""Simplification of the fine surface M_S to the coarse surface M'_S (paper §5, steps 1-2, eq 13-14).

The paper picks a minimum vertex cover V of M_S's edge graph and merges every vertex p_i outside V into one
neighbour p_j in V: the edge p_i p_j disappears, edges p_i p_k to common neighbours p_k disappear, and the others
are relinked to p_j. That is a *half-edge collapse* p_i -> p_j, so every surviving vertex is an original M_S vertex
at its original position (bit for bit). The neighbour is chosen by eq 13-14: the p_k whose distance d_ik is closest
to the mean neighbour distance d_avg.

Choices where the paper is silent (see docs/hybrid-mesh.md):

* **Cover.** Minimum vertex cover is NP-hard (paper ref 22). We take the complement of a greedy *maximal
  independent set* I built in order of increasing vertex degree (the minimum-degree greedy heuristic, a classic
  approximation of the maximum independent set, hence of the minimum cover), ties broken by a fixed pseudo-random
  rank. V = vertices \\ I is a vertex cover, and every neighbour of a vertex in I lies in V, as eq 13-14 needs.
* **Rounds.** One round removes at most |I| (about a quarter to a third of a triangulation's vertices), yet Table 1's
  coarse meshes are about 3x smaller, so rounds repeat, each with a fresh cover of the current mesh, until
  ``target_vertices`` remain. Within a round the vertices of I are processed in rank order, so a round stopped at
  the target leaves its unprocessed vertices spread evenly over the surface instead of in one patch.
* **Safety.** A collapse is skipped (and counted) if it would break the link condition (non-manifold result),
  give a triangle of normalised quality ``4 sqrt(3) A / (l1² + l2² + l3²)`` below ``min_quality`` (degenerate),
  turn a triangle's normal by more than ``max_normal_change`` (flip; also keeps sharp features such as a cube's
  edges), fold two adjacent triangles beyond ``max_fold`` (a local self-overlap), create a self-intersection with any
  nearby triangle (exact-predicate-style segment/triangle tests against every triangle whose bounding box can
  reach, found through a uniform grid of vertices), or raise a vertex degree above ``MAX_DEGREE``. When the eq-14
  neighbour is refused, the next neighbour in eq-14 order is tried (a vertex is kept only when no neighbour works).

Everything is deterministic: the same input gives bit-identical output.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from ..errors import MeshError
from .surface import SurfaceMesh

# Coarse/fine vertex ratio of the default target. Table 1's M_V has 0.34-0.42 of M_S's nodes; TetGen's quality
# switches add some interior nodes to M_V (tetrahedralize.COARSE_SWITCHES), so the coarse *surface* aims lower.
DEFAULT_RATIO = 0.32
MAX_NORMAL_CHANGE_DEG = 40.0     # a collapse may turn a triangle's normal by at most this much
MAX_FOLD_DEG = 140.0             # dihedral fold allowed between new adjacent triangles (a cube edge is 90°)
MIN_QUALITY = 0.15               # 1 for equilateral; 0.15 ~ a 160° or a 6° angle
MAX_DEGREE = 48                  # per-vertex triangle capacity of the kernel's incidence table
MAX_ROUNDS = 100
MIN_VERTICES = 8

# Order of the reject counters returned by the kernel.
REJECT_REASONS = ("link", "degree", "degenerate", "normal", "fold", "intersection")


@dataclass(frozen=True)
class SimplifyReport:
    """What the simplifier did.

    Attributes:
        target_vertices: requested vertex count of M'_S.
        vertices: vertex count reached (> target only if no allowed collapse was left).
        rounds: vertex-cover rounds run.
        collapses: half-edge collapses done.
        rejected: refused collapse attempts by reason (``link``, ``degree``, ``degenerate``, ``normal``, ``fold``,
            ``intersection``); one vertex may count several attempts (one per neighbour tried).
        kept: vertices of a cover's complement that no neighbour could absorb.
        seconds: wall time [s].
    """

    target_vertices: int
    vertices: int
    rounds: int
    collapses: int
    rejected: dict = field(default_factory=dict)
    kept: int = 0
    seconds: float = 0.0

    @property
    def reached(self) -> bool:
        return self.vertices <= self.target_vertices

    def as_dict(self) -> dict:
        return {"target_vertices": self.target_vertices, "vertices": self.vertices, "rounds": self.rounds,
                "collapses": self.collapses, "rejected": dict(self.rejected), "kept": self.kept,
                "seconds": self.seconds}


@dataclass(frozen=True, eq=False)
class Simplified:
    """Result of :func:`simplify`.

    Attributes:
        surface: M'_S; its vertices are ``fine.vertices[kept]`` (bit-identical), triangles ``(t, 3) int32``.
        kept: ``(c,) int32`` ascending M_S vertex indices of M'_S's vertices (the control nodes).
        report: counts and timing.
    """

    surface: SurfaceMesh
    kept: np.ndarray
    report: SimplifyReport


def default_target(vertex_count: int) -> int:
    """Default M'_S vertex count for an M_S of ``vertex_count`` vertices (see :data:`DEFAULT_RATIO`)."""
    return max(MIN_VERTICES, int(round(DEFAULT_RATIO * vertex_count)))


def simplify(surface: SurfaceMesh, *, target_vertices: int | None = None,
             max_normal_change: float = MAX_NORMAL_CHANGE_DEG, max_fold: float = MAX_FOLD_DEG,
             min_quality: float = MIN_QUALITY, max_rounds: int = MAX_ROUNDS) -> Simplified:
    """Simplify a closed, manifold, outward-oriented surface M_S to M'_S (§5) by repeated vertex-cover rounds.

    Args:
        surface: M_S; should have passed :func:`tissuesim.mesh.validate.validate_surface`.
        target_vertices: vertex count to reach (default :func:`default_target`); at least 8.
        max_normal_change: largest turn of a triangle's normal a collapse may cause [degrees].
        max_fold: largest fold between two adjacent triangles a collapse may create [degrees].
        min_quality: smallest normalised triangle quality a collapse may create (0..1).
        max_rounds: upper bound on cover rounds.

    Returns:
        :class:`Simplified` with M'_S, the kept M_S indices and a :class:`SimplifyReport`.
    """
    start = time.perf_counter()
    n = surface.vertex_count
    target = default_target(n) if target_vertices is None else int(target_vertices)
    if target < MIN_VERTICES:
        raise MeshError(f"target_vertices must be at least {MIN_VERTICES}, got {target}; ask for more vertices")
    if not 0.0 < max_normal_change < 180.0 or not 0.0 < max_fold < 180.0:
        raise MeshError("max_normal_change and max_fold must lie in (0, 180) degrees")
    if not 0.0 <= min_quality < 1.0:
        raise MeshError(f"min_quality must lie in [0, 1), got {min_quality}")
    vertices = surface.vertices
    triangles = np.array(surface.triangles, dtype=np.int32)
    degree = np.bincount(triangles.ravel(), minlength=n)
    if np.any(degree == 0):
        raise MeshError(f"{int(np.sum(degree == 0))} vertices belong to no triangle; remove unused vertices first")
    if degree.max() > MAX_DEGREE:
        raise MeshError(f"a vertex has {degree.max()} triangles, more than the {MAX_DEGREE} supported; remesh it")
    # Fixed pseudo-random rank: deterministic tie-break that spreads each round's collapses over the surface.
    rank = np.random.default_rng(20240513).permutation(n).astype(np.int64)
    cell, origin, dims, cell_start, cell_vertices = _vertex_grid(vertices, triangles)
    tri_alive, counters, rejected = _simplify_kernel(
        vertices, triangles, rank, target, np.cos(np.radians(max_normal_change)), np.cos(np.radians(max_fold)),
        float(min_quality), int(max_rounds), cell, origin, dims, cell_start, cell_vertices, MAX_DEGREE)
    kept_triangles = triangles[tri_alive]
    kept = np.unique(kept_triangles).astype(np.int32)
    remap = np.full(n, -1, dtype=np.int32)
    remap[kept] = np.arange(len(kept), dtype=np.int32)
    coarse = SurfaceMesh(vertices[kept], remap[kept_triangles])
    report = SimplifyReport(
        target_vertices=target, vertices=len(kept), rounds=int(counters[0]), collapses=int(counters[1]),
        rejected={reason: int(c) for reason, c in zip(REJECT_REASONS, rejected)}, kept=int(counters[2]),
        seconds=time.perf_counter() - start)
    return Simplified(coarse, kept, report)


def _vertex_grid(vertices: np.ndarray, triangles: np.ndarray):
    """A uniform grid over the vertices (CSR: ``cell_start``, ``cell_vertices``), about one vertex per cell."""
    lo = vertices.min(axis=0)
    extent = np.maximum(np.ptp(vertices, axis=0), 1e-12)
    edge = vertices[triangles[:, 1]] - vertices[triangles[:, 0]]
    mean_edge = float(np.linalg.norm(edge, axis=1).mean())
    # At least twice the mean edge, and no more cells than about the vertex count (flat shapes included).
    cell = max(2.0 * mean_edge, float((np.prod(extent) / len(vertices)) ** (1.0 / 3.0)))
    dims = np.minimum(np.floor(extent / cell).astype(np.int64) + 1, 256)
    cell = float(max(cell, np.max(extent / dims)))
    ijk = np.minimum(((vertices - lo) / cell).astype(np.int64), dims - 1)
    flat = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    order = np.argsort(flat, kind="stable").astype(np.int32)
    cell_start = np.zeros(int(np.prod(dims)) + 1, dtype=np.int64)
    np.add.at(cell_start, flat + 1, 1)
    return cell, lo.astype(np.float64), dims, np.cumsum(cell_start), order


# ---------------------------------------------------------------------------------------------------------------
# Numba kernel: all rounds in one call. Data: triangles (relabelled in place), tri_alive, a vertex -> triangle
# incidence table ``vt`` (capacity MAX_DEGREE), vertex liveness. Positions never change.


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


@njit(cache=True)
def _remove_incidence(vt, vt_n, v, t):
    for k in range(vt_n[v]):
        if vt[v, k] == t:
            vt[v, k] = vt[v, vt_n[v] - 1]
            vt_n[v] -= 1
            return


@njit(cache=True)
def _collapse(P, T, tri_alive, vt, vt_n, v_alive, reach, i, j, lmax):
    """Half-edge collapse i -> j: drop the two triangles on edge ij, relabel i's other triangles to j."""
    for k in range(vt_n[i]):
        t = vt[i, k]
        if T[t, 0] == j or T[t, 1] == j or T[t, 2] == j:
            tri_alive[t] = False
            for u in range(3):
                if T[t, u] != i:
                    _remove_incidence(vt, vt_n, T[t, u], t)
        else:
            for u in range(3):
                if T[t, u] == i:
                    T[t, u] = j
                else:
                    d = _sub(_v(P, T[t, u]), _v(P, j))
                    length = np.sqrt(_dot(d, d))
                    lmax = max(lmax, length)
                    reach[j] = max(reach[j], length)
                    reach[T[t, u]] = max(reach[T[t, u]], length)
            vt[j, vt_n[j]] = t
            vt_n[j] += 1
    vt_n[i] = 0
    v_alive[i] = False
    return lmax


@njit(cache=True)
def _simplify_kernel(P, T, rank, target, cos_normal, cos_fold, min_quality, max_rounds,
                     cell, origin, dims, cell_start, cell_vertices, cap):
    n = P.shape[0]
    m = T.shape[0]
    tri_alive = np.ones(m, dtype=np.bool_)
    v_alive = np.ones(n, dtype=np.bool_)
    vt = np.full((n, cap), -1, dtype=np.int64)
    vt_n = np.zeros(n, dtype=np.int64)
    reach = np.zeros(n)      # longest edge at each vertex [m]
    lmax = 0.0
    for t in range(m):
        for u in range(3):
            v = T[t, u]
            w = T[t, (u + 1) % 3]
            vt[v, vt_n[v]] = t
            vt_n[v] += 1
            d = _sub(_v(P, w), _v(P, v))
            length = np.sqrt(_dot(d, d))
            lmax = max(lmax, length)
            reach[v] = max(reach[v], length)
            reach[w] = max(reach[w], length)
    counters = np.zeros(3, dtype=np.int64)      # rounds, collapses, kept
    rejected = np.zeros(6, dtype=np.int64)
    stamp = np.zeros(m, dtype=np.int64)
    stamp_counter = np.zeros(1, dtype=np.int64)
    nb_i = np.empty(2 * cap + 2, dtype=np.int64)
    nb_j = np.empty(2 * cap + 2, dtype=np.int64)
    nb = np.empty(2 * cap + 2, dtype=np.int64)
    alive = n
    blocked = np.zeros(n, dtype=np.bool_)
    in_set = np.zeros(n, dtype=np.bool_)
    for _round in range(max_rounds):
        if alive <= target:
            break
        counters[0] += 1
        # Greedy maximal independent set in order of (degree, rank); its complement is the vertex cover V.
        key = np.empty(n, dtype=np.int64)
        for v in range(n):
            key[v] = vt_n[v] * n + rank[v] if v_alive[v] else (cap + 1) * n + rank[v]
        order = np.argsort(key)
        blocked[:] = False
        in_set[:] = False
        for v in order:
            if not v_alive[v] or blocked[v]:
                continue
            in_set[v] = True
            cnt = _neighbours(T, vt, vt_n, v, nb)
            for a in range(cnt):
                blocked[nb[a]] = True
        # Merge each vertex of I into a neighbour (all in V), in rank order.
        by_rank = np.argsort(rank)
        done = 0
        for v in by_rank:
            if alive <= target:
                break
            if not in_set[v] or not v_alive[v]:
                continue
            cnt = _neighbours(T, vt, vt_n, v, nb)
            dist = np.empty(cnt)
            for a in range(cnt):
                d = _sub(_v(P, nb[a]), _v(P, v))
                dist[a] = np.sqrt(_dot(d, d))
            d_avg = dist.sum() / cnt                                 # eq 13
            candidates = np.argsort(np.abs(dist - d_avg), kind="mergesort")   # eq 14 first, then the next best
            merged = False
            for a in candidates:
                j = nb[a]
                verdict = _check_collapse(P, T, vt, vt_n, reach, v, j, cos_normal, cos_fold, min_quality, cap, lmax,
                                          cell, origin, dims, cell_start, cell_vertices, stamp, stamp_counter,
                                          nb_i, nb_j)
                if verdict == 0:
                    lmax = _collapse(P, T, tri_alive, vt, vt_n, v_alive, reach, v, j, lmax)
                    alive -= 1
                    done += 1
                    counters[1] += 1
                    merged = True
                    break
                rejected[verdict - 1] += 1
            if not merged:
                counters[2] += 1
        if done == 0:
            break
    return tri_alive, counters, rejected
