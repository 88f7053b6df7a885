"""The static data of a cut hybrid mesh: M_S cut, M_V and M'_S unchanged, maps extended to the new vertices.

A new vertex (an edge or facet point) gets the §6.1 load map (the closest point on M'_S, searched among its parents'
coarse triangles) and its embedding in M_V (the parents' tet that holds it best: the largest smallest
barycentric coordinate, unclamped so it reproduces the point); a duplicate takes its original's. A vertex moved
onto the cut (:mod:`.moves`) keeps its coarse triangle and its tet, with the coordinates of where it now is (so
the solvers' per-vertex node lists stay valid): the closest point of that coarse triangle, and unclamped
coordinates in that tet. Control nodes on
the cut are released (§7, last sentence): ``control`` and ``control_volume`` keep the others, and
``coarse_volume`` keeps the M_V node of every M'_S vertex. The fine reference volume is not cut (its
re-tetrahedralization is what the hybrid avoids), so a cut mesh has none.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..mesh.hybrid import SURFACE_EDGE_KEY, SURFACE_VERTICES_KEY, HybridMesh
from ..mesh.maps import closest_among
from ..mesh.surface import SurfaceMesh
from .buffers import Spare
from .result import CutResult


def new_rows(values: np.ndarray, result: CutResult, fresh: np.ndarray) -> np.ndarray:
    """``(v, ...)`` rows of per-vertex ``values`` ``(n, ...)`` for the new vertices: ``fresh`` for the inserted
    points (in order), each duplicate its original's (an old vertex or an inserted point)."""
    n = result.old_count
    copy_of = result.new_copy_of
    points = copy_of < 0
    out = np.empty((len(copy_of),) + values.shape[1:], dtype=values.dtype)
    out[points] = fresh
    copies = np.flatnonzero(~points)
    of = copy_of[copies]
    old = of < n
    out[copies[old]] = values[of[old]]
    out[copies[~old]] = out[of[~old] - n]
    return out


def cut_hybrid(hybrid: HybridMesh, result: CutResult, released: np.ndarray, spare: Spare) -> HybridMesh:
    """The hybrid mesh after ``result``, with the control nodes ``released`` ``(r,) int`` no longer prescribed.

    Its surface and per-vertex maps are views of the capacity buffers ``spare`` (their rows before the cut are
    shared with ``hybrid``'s, see :mod:`tissuesim.cutting.buffers`); the surface is not validated again (the cut
    keeps its invariants: :func:`~tissuesim.cutting.invariants.check_cut_invariants`)."""
    points = np.flatnonzero(result.new_copy_of < 0)
    rest = result.rest[result.old_count + points]
    parents = result.parents[points]
    coarse_tri, coarse_bary = _load_map(hybrid, rest, parents)
    tet, tet_bary = _embedding(hybrid, rest, parents)
    control, control_volume = hybrid.control, hybrid.control_volume
    if released.size:
        keep = ~np.isin(control, released)
        control, control_volume = control[keep], control_volume[keep]
    info = dict(hybrid.info)
    # what a solver built later on the cut mesh needs to give every row the thickness the cutting solver gave it
    # (a mesh built before these keys were stored is uncut here, so its own figures are the built ones)
    info.setdefault(SURFACE_EDGE_KEY, hybrid.built_edge_length)
    info.setdefault(SURFACE_VERTICES_KEY, hybrid.surface.vertex_count)
    info["cuts"] = int(info.get("cuts", 0)) + 1
    maps = {name: spare.extend(name, getattr(hybrid, name), new_rows(getattr(hybrid, name), result, fresh))
            for name, fresh in (("coarse_triangle", coarse_tri), ("coarse_barycentric", coarse_bary),
                                ("embedding_tet", tet), ("embedding_barycentric", tet_bary))}
    if len(result.moved):
        _remap_moved(hybrid, result, maps, spare)
    return dataclasses.replace(
        hybrid, surface=SurfaceMesh.trusted(result.rest, result.triangles), control=control,
        control_volume=control_volume, coarse_volume=hybrid.coarse_volume_nodes, fine_volume=None,
        fine_surface_nodes=None, info=info, **maps)


def _remap_moved(hybrid, result: CutResult, maps: dict, spare: Spare) -> None:
    """The moved vertices' load-map and embedding coordinates where they now are, in the same coarse triangle and
    tet (rewritten in the buffers, so a move taken back puts them back)."""
    moved = result.moved
    rest = result.rest[moved]
    coarse = hybrid.coarse_surface
    rows = maps["coarse_triangle"][moved].astype(np.int64)
    bary = np.stack([closest_among(coarse.vertices, coarse.triangles, p[None], r[None])[1][0]
                     for p, r in zip(rest, rows)])
    spare.rewrite(maps["coarse_barycentric"], moved, bary)
    volume = hybrid.volume
    corners = volume.points[volume.tets[maps["embedding_tet"][moved]]]              # (k, 4, 3)
    local = np.linalg.solve(np.swapaxes(corners[:, 1:] - corners[:, :1], 1, 2), (rest - corners[:, 0])[..., None])
    local = local[..., 0]
    spare.rewrite(maps["embedding_barycentric"], moved, np.concatenate([1.0 - local.sum(axis=1, keepdims=True),
                                                                         local], axis=1))


def _load_map(hybrid, rest, parents):
    """§6.1 map of new points: closest point on M'_S among the parents' coarse triangles."""
    if len(rest) == 0:
        return np.zeros(0, dtype=np.int32), np.zeros((0, 3))
    candidates = np.unique(hybrid.coarse_triangle[parents])
    coarse = hybrid.coarse_surface
    tri, bary, _ = closest_among(coarse.vertices, coarse.triangles, rest, candidates)
    return tri.astype(np.int32), bary


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
