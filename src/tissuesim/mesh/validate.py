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
* **Self-intersection**: :mod:`tissuesim.mesh.intersections` (its docstring says what counts).
* **Components** are vertex-connected pieces (two tetrahedra sharing one vertex are one component with a
  non-manifold vertex).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import MeshError, first_indices
from .intersections import crossing_pairs
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


def self_intersections(surface: SurfaceMesh) -> np.ndarray:
    """``(k, 2) int64`` triangle pairs ``(i, j)``, ``i < j``, sorted, that intersect improperly
    (:mod:`tissuesim.mesh.intersections`). Degenerate triangles are skipped (their planes are undefined;
    :func:`degenerate_triangles` reports them)."""
    return crossing_pairs(surface, degenerate_triangles(surface))


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


def validate_surface(surface: SurfaceMesh, *, source: str | None = None) -> None:
    """Raise :class:`MeshError` naming every defect of ``surface`` (see :func:`surface_defects`), and the file it
    was read from where ``source`` is given; else return."""
    defects = surface_defects(surface)
    if defects:
        raise MeshError(f"invalid surface{'' if source is None else f' {source}'}: " + "; ".join(defects))
