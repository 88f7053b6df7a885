"""The static data of a cut hybrid mesh: M_S cut, M_V and M'_S unchanged, maps extended to the new vertices.

A new vertex (an edge or facet point) gets the §6.1 load map (the closest point on M'_S, searched among its parents'
coarse triangles) and its embedding in M_V (the parents' tet that holds it best: the largest smallest
barycentric coordinate, unclamped so it reproduces the point); a duplicate takes its original's. Control nodes on
the cut are released (§7, last sentence): ``control`` and ``control_volume`` keep the others, and
``coarse_volume`` keeps the M_V node of every M'_S vertex. The fine reference volume is not cut (its
re-tetrahedralization is what the hybrid avoids), so a cut mesh has none.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..mesh.hybrid import HybridMesh
from ..mesh.maps import closest_on_surface
from ..mesh.surface import SurfaceMesh
from .core import CutResult


def new_vertex_order(result: CutResult, old_count: int) -> tuple[np.ndarray, np.ndarray]:
    """``(points, copies)``: indices of the inserted points and of the duplicates among the new vertices."""
    new = np.arange(old_count, len(result.rest))
    copies = new[result.copy_of[new] >= 0]
    return new[result.copy_of[new] < 0], copies


def interpolate(values: np.ndarray, result: CutResult, old_count: int) -> np.ndarray:
    """``values`` ``(n, ...)`` per old vertex extended to the cut mesh by the parents' barycentric weights."""
    extra = np.einsum("ij,ij...->i...", result.weights, values[result.parents])
    return np.concatenate([values, extra])


def extend(values: np.ndarray, result: CutResult, old_count: int, fresh: np.ndarray) -> np.ndarray:
    """``values`` per old vertex, then ``fresh`` for the inserted points, then each duplicate's original's."""
    points, copies = new_vertex_order(result, old_count)
    out = np.empty((len(result.rest),) + values.shape[1:], dtype=values.dtype)
    out[:old_count] = values
    out[points] = fresh
    out[copies] = out[result.copy_of[copies]]
    return out


def cut_hybrid(hybrid: HybridMesh, result: CutResult, released: np.ndarray) -> HybridMesh:
    """The hybrid mesh after ``result``, with the control nodes ``released`` ``(r,) int`` no longer prescribed."""
    n = hybrid.surface.vertex_count
    points, _ = new_vertex_order(result, n)
    rest = result.rest[points]
    parents = result.parents[points - n]
    coarse_tri, coarse_bary = _load_map(hybrid, rest, parents)
    tet, tet_bary = _embedding(hybrid, rest, parents)
    keep = ~np.isin(hybrid.control, released, kind="table") if released.size else np.ones(len(hybrid.control), bool)
    info = dict(hybrid.info)
    info["cuts"] = int(info.get("cuts", 0)) + 1
    return dataclasses.replace(
        hybrid, surface=SurfaceMesh(result.rest, result.triangles), control=hybrid.control[keep],
        control_volume=hybrid.control_volume[keep], coarse_volume=hybrid.coarse_volume_nodes,
        coarse_triangle=extend(hybrid.coarse_triangle, result, n, coarse_tri),
        coarse_barycentric=extend(hybrid.coarse_barycentric, result, n, coarse_bary),
        embedding_tet=extend(hybrid.embedding_tet, result, n, tet),
        embedding_barycentric=extend(hybrid.embedding_barycentric, result, n, tet_bary),
        fine_volume=None, fine_surface_nodes=None, info=info)


def _load_map(hybrid, rest, parents):
    """§6.1 map of new points: closest point on M'_S among the parents' coarse triangles."""
    if len(rest) == 0:
        return np.zeros(0, dtype=np.int32), np.zeros((0, 3))
    candidates = np.unique(hybrid.coarse_triangle[parents])
    coarse = hybrid.coarse_surface
    corners, local_triangles = np.unique(coarse.triangles[candidates], return_inverse=True)
    local = SurfaceMesh(coarse.vertices[corners], local_triangles.reshape(-1, 3))   # a few triangles, renumbered
    tri, bary = closest_on_surface(local, rest)
    return candidates[tri].astype(np.int32), bary


def _embedding(hybrid, rest, parents):
    """Embedding of new points in M_V: among the parents' tets, the one with the largest smallest coordinate."""
    if len(rest) == 0:
        return np.zeros(0, dtype=np.int32), np.zeros((0, 4))
    volume = hybrid.volume
    tets = hybrid.embedding_tet[parents]                      # (k, 3) candidates
    corners = volume.points[volume.tets[tets]]                # (k, 3, 4, 3)
    edges = np.swapaxes(corners[:, :, 1:] - corners[:, :, :1], 2, 3)     # columns p1 − p0, p2 − p0, p3 − p0
    local = np.linalg.solve(edges, (rest[:, None, :] - corners[:, :, 0])[..., None])[..., 0]
    bary = np.concatenate([1.0 - local.sum(axis=2, keepdims=True), local], axis=2)    # (k, 3, 4)
    best = np.argmax(bary.min(axis=2), axis=1)
    rows = np.arange(len(rest))
    return tets[rows, best].astype(np.int32), bary[rows, best]
