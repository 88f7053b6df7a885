"""What must hold after every cut (tests, the fuzz test and ``tissuesim incise`` call :func:`check_cut_invariants`).

Each check returns a sentence naming the defect and the first offenders; an empty list means the surface is sound:

* every vertex is in a triangle, every edge has one or two triangles;
* vertex-manifold: the triangles around each vertex form one fan (joined through shared edges);
* consistent orientation: an interior edge is walked once in each direction;
* no triangle below :data:`MIN_QUALITY` (4√3 A / Σ l², 1 for equilateral) or a zero area, at rest and now;
* Euler characteristic: χ = V − E + F = Σ over components of 2 − 2g − b; the genus g it implies must be a whole
  number between 0 and ``max_genus`` (cutting never adds a handle; an interior slit on a sphere: χ = 1);
* optionally, every piece (connected component) holds an ``anchored`` node (a fixed or control node: what holds
  it in place), so no piece cut loose drifts;
* optionally, constraint rest lengths equal the rest distances (eq 19–23 are exact for the new rest positions),
  one live stretch constraint per edge, and the total mass is conserved.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import first_indices

#: Smallest triangle quality 4√3 A / (l1² + l2² + l3²) allowed, at rest and now. Snapping (σ = 0.25 by default)
#: keeps new points at least σ times the local edge length or height away from edges and vertices; this floor
#: (a height of about 1 % of the longest side) is what the PBD kernels' degeneracy thresholds stay far above.
MIN_QUALITY = 0.01
#: Relative tolerance on rest lengths and the total mass.
RELATIVE_TOLERANCE = 1e-9


def triangle_qualities(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(m,) float64`` 4√3 A / (l1² + l2² + l3²) of each triangle of ``points`` ``(n, 3)`` [m]."""
    p = points[triangles]
    area2 = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    squares = np.sum((p - p[:, [1, 2, 0]]) ** 2, axis=(1, 2))
    return 2.0 * np.sqrt(3.0) * area2 / np.where(squares > 0.0, squares, 1.0)


def check_cut_invariants(rest: np.ndarray, triangles: np.ndarray, *, positions: np.ndarray | None = None,
                         max_genus: int = 0, min_quality: float = MIN_QUALITY, edges: np.ndarray | None = None,
                         rest_length: np.ndarray | None = None, masses: np.ndarray | None = None,
                         total_mass: float | None = None, anchored: np.ndarray | None = None) -> list[str]:
    """Defects of a (cut) surface; ``[]`` when every invariant holds (see the module docstring).

    Args:
        rest: ``(n, 3) float64`` rest positions [m]. triangles: ``(m, 3) int``.
        positions: ``(n, 3) float64`` current positions [m] (quality "now"), optional.
        max_genus: the genus of the uncut surface (0 for the built-in models).
        min_quality: quality floor (default :data:`MIN_QUALITY`).
        edges, rest_length: ``(e, 2) int``, ``(e,) float64`` [m] the live stretch constraints, optional.
        masses: ``(n,) float64`` [kg] node masses and ``total_mass`` [kg] the mass before any cut, optional.
        anchored: ``(a,) int`` the nodes that hold the surface in place (a solver's fixed and control nodes:
            :func:`~tissuesim.solvers.cut_carry.anchored_nodes`), optional: every piece must hold one.
    """
    triangles = np.asarray(triangles, dtype=np.int64)
    n, problems = len(rest), []
    unused = np.setdiff1d(np.arange(n), triangles.ravel())
    if unused.size:
        problems.append(f"{unused.size} vertices are in no triangle (first: {first_indices(unused)})")
    directed = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    key = np.minimum(directed[:, 0], directed[:, 1]) * n + np.maximum(directed[:, 0], directed[:, 1])
    unique, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    over = np.flatnonzero(counts > 2)
    if over.size:
        problems.append(f"{over.size} edges have more than two triangles (first: {_pairs(unique[over], n)})")
    _, dcounts = np.unique(directed[:, 0] * n + directed[:, 1], return_counts=True)
    if np.any(dcounts > 1):
        problems.append(f"{int(np.sum(dcounts > 1))} edges are walked twice in one direction: the orientation "
                        "is inconsistent")
    problems += _manifold(triangles, inverse, n)
    for name, points in (("rest", rest), ("now", positions)):
        if points is None:
            continue
        q = triangle_qualities(points, triangles)
        bad = np.flatnonzero(~(q >= min_quality))
        if bad.size:
            problems.append(f"{bad.size} triangles are slivers {name} (quality < {min_quality:g}; first: "
                            f"{first_indices(bad)}, worst {q[bad].min():.3g})")
    problems += _euler(triangles, unique, counts, n, max_genus)
    if anchored is not None:
        loose, pieces, first = unanchored_pieces(triangles, n, anchored)
        if loose:
            which = "1 piece" if pieces == 1 else f"{pieces} pieces"
            problems.append(f"{which} ({loose} vertices; first: {first}) hold no anchored (fixed or control) node "
                            "and would drift")
    if edges is not None:
        problems += _lengths(rest, np.asarray(edges, dtype=np.int64), rest_length, unique, n)
    if masses is not None and total_mass is not None:
        total = float(np.sum(masses))
        if abs(total - total_mass) > RELATIVE_TOLERANCE * abs(total_mass):
            problems.append(f"total mass changed from {total_mass:.12g} kg to {total:.12g} kg")
    return problems


def unanchored_pieces(triangles: np.ndarray, n: int, anchored: np.ndarray, *,
                      near: np.ndarray | None = None) -> tuple[int, int, int]:
    """``(vertices, pieces, first vertex)`` of the pieces of a surface that hold none of the ``anchored`` vertices
    (``(0, 0, -1)`` if none). One compiled union-find pass over the triangles, O(n + m).

    Args:
        triangles: ``(m, 3) int`` rows; n: the vertex count. anchored: ``(a,) int`` vertices that hold a piece.
        near: ``(k,) int`` only the pieces holding one of these vertices count (a cut's own: the pieces it may
            have cut loose), default every piece.
    """
    return _unanchored(np.asarray(triangles), n, np.asarray(anchored, dtype=np.int64),
                       np.arange(n, dtype=np.int64) if near is None else np.asarray(near, dtype=np.int64))


@njit(cache=True)
def _unanchored(triangles, n, anchored, near):
    parent = np.arange(n)
    used = np.zeros(n, dtype=np.bool_)
    for r in range(triangles.shape[0]):
        _join(parent, used, triangles[r, 0], triangles[r, 1], triangles[r, 2])
    flag = np.zeros(n, dtype=np.int8)      # per root: 1 a vertex of ``near``, 2 an anchored vertex
    for v in near:
        if used[v]:
            flag[_root(parent, v)] |= 1
    for v in anchored:
        flag[_root(parent, v)] |= 2
    vertices, pieces, first = 0, 0, -1
    for v in range(n):
        if used[v]:
            root = _root(parent, v)
            if flag[root] == 1:
                vertices += 1
                first = v if first < 0 else first
                if root == v:
                    pieces += 1
    return vertices, pieces, first


@njit(cache=True)
def _root(parent, v):
    while parent[v] != v:
        parent[v] = parent[parent[v]]      # path halving
        v = parent[v]
    return v


@njit(cache=True)
def _join(parent, used, a, b, c):
    used[a] = used[b] = used[c] = True
    ra, rb, rc = _root(parent, a), _root(parent, b), _root(parent, c)
    low = min(ra, rb, rc)          # the lowest root: a piece's root is its lowest vertex
    parent[ra] = parent[rb] = parent[rc] = low


def _manifold(triangles, edge_of_half, n):
    """Corners of one vertex joined across the edges they share must form a single group per vertex."""
    m = len(triangles)
    corner = np.arange(3 * m).reshape(m, 3)
    # half-edge h = 3t + k runs from corner k to corner k+1 of triangle t
    a_corner = corner.ravel()
    b_corner = corner[:, [1, 2, 0]].ravel()
    order = np.argsort(edge_of_half, kind="stable")
    e_sorted = edge_of_half[order]
    pair = np.flatnonzero(e_sorted[1:] == e_sorted[:-1])
    h1, h2 = order[pair], order[pair + 1]
    vertex = triangles.ravel()
    rows, cols = [], []
    for x in (a_corner, b_corner):
        for y in (a_corner, b_corner):
            same = vertex[x[h1]] == vertex[y[h2]]
            rows.append(x[h1][same])
            cols.append(y[h2][same])
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * m, 3 * m))
    _, label = connected_components(graph, directed=False)
    groups = np.unique(np.stack([vertex, label], axis=1), axis=0)
    fans = np.bincount(groups[:, 0], minlength=n)
    bad = np.flatnonzero(fans > 1)
    if bad.size:
        return [f"{bad.size} vertices are not manifold (their triangles form several fans; first: "
                f"{first_indices(bad)})"]
    return []


def _euler(triangles, unique_edges, counts, n, max_genus):
    used = np.unique(triangles)
    chi = len(used) - len(unique_edges) + len(triangles)
    rows = np.repeat(np.arange(len(triangles)), 3)
    graph = coo_matrix((np.ones(rows.size), (rows, triangles.ravel())), shape=(len(triangles), n)).tocsr()
    components, _ = connected_components(graph @ graph.T, directed=False)
    loops = _loops(unique_edges[counts == 1], n)
    twice_genus = 2 * components - loops - chi
    if twice_genus % 2 or not 0 <= twice_genus // 2 <= max_genus:
        return [f"Euler characteristic {chi} with {components} components and {loops} boundary loops implies "
                f"genus {twice_genus / 2:g}, outside 0..{max_genus}"]
    return []


def boundary_loops(triangles: np.ndarray, n: int) -> int:
    """Number of boundary loops (the openings a cut made) of ``triangles`` ``(m, 3)`` over n vertices."""
    triangles = np.asarray(triangles, dtype=np.int64)
    directed = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    key = directed[:, 0] * n + directed[:, 1]
    unique, counts = np.unique(key, return_counts=True)
    return _loops(unique[counts == 1], n)


def _loops(boundary_keys, n):
    if boundary_keys.size == 0:
        return 0
    a, b = boundary_keys // n, boundary_keys % n
    _, label = connected_components(coo_matrix((np.ones(a.size), (a, b)), shape=(n, n)), directed=False)
    return np.unique(label[np.concatenate([a, b])]).size


def _lengths(rest, edges, rest_length, unique_edges, n):
    problems = []
    live = edges[:, 0] != edges[:, 1]
    e = edges[live]
    key = np.minimum(e[:, 0], e[:, 1]) * n + np.maximum(e[:, 0], e[:, 1])
    missing = np.setdiff1d(unique_edges, key)
    if missing.size:
        problems.append(f"{missing.size} surface edges have no stretch constraint (first: {_pairs(missing, n)})")
    stray = np.setdiff1d(key, unique_edges)
    if stray.size:
        problems.append(f"{stray.size} stretch constraints join nodes that share no edge (first: "
                        f"{_pairs(stray, n)}): a constraint across the cut")
    if np.unique(key).size != key.size:
        problems.append(f"{key.size - np.unique(key).size} edges have more than one stretch constraint")
    if rest_length is not None:
        length = np.linalg.norm(rest[e[:, 0]] - rest[e[:, 1]], axis=1)
        wrong = np.flatnonzero(np.abs(np.asarray(rest_length)[live] - length) > RELATIVE_TOLERANCE * length)
        if wrong.size:
            problems.append(f"{wrong.size} rest lengths differ from the rest distances (first constraints: "
                            f"{first_indices(np.flatnonzero(live)[wrong])})")
    return problems


def _pairs(keys, n, limit=3):
    return ", ".join(f"({k // n}, {k % n})" for k in keys[:limit])
