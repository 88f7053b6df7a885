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
from .collapse import _check_collapse, _dot, _neighbours, _sub, _v
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
