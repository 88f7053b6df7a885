"""Safe repairs of a triangle surface, each reported in words: what ``read_surface(..., repair=True)`` does.

What is repaired, in this order (anything else is left for :func:`~tissuesim.mesh.validate.validate_surface` to
refuse):

1. **Degenerate triangles** (repeated vertex, zero area) are removed only if the surface stays closed without them
   (e.g. a ``(a, a, b)`` sliver or a duplicated face pair); a zero-area triangle with three distinct corners in a
   closed surface would leave a slit, so it is kept and reported.
2. **Inconsistent orientation**: a breadth-first walk over each connected piece flips every triangle that walks a
   shared edge the same way as its already-oriented neighbour (the first triangle of each piece keeps its order).
3. **Inward orientation**: if the signed volume is negative, every triangle is reversed. Vertices are untouched.
4. **Self-intersections**: pymeshfix (optional extra ``tissuesim[repair]``) removes the intersecting triangles and
   refills the holes; this moves and renumbers vertices, so it is reported with the counts before and after.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ..errors import MeshError
from .surface import SurfaceMesh
from .validate import boundary_edges, degenerate_triangles, faces_inward, inconsistent_edges, self_intersections


def repair_surface(surface: SurfaceMesh) -> tuple[SurfaceMesh, list[str]]:
    """Repair what is safe (see the module docstring); return the new surface and one line per change made.

    The result is not validated here: call :func:`~tissuesim.mesh.validate.validate_surface` on it (``read_surface``
    does). An empty list means nothing was changed and the same object is returned.

    Raises:
        MeshError: self-intersections are present and pymeshfix is not installed.
    """
    changes: list[str] = []
    surface = _remove_degenerate(surface, changes)
    surface = _orient(surface, changes)
    crossings = self_intersections(surface)
    if len(crossings):
        surface = _meshfix(surface, len(crossings), changes)
        surface = _orient(surface, changes)
    return surface, changes


def _drop_unused(vertices: np.ndarray, triangles: np.ndarray) -> SurfaceMesh:
    used = np.zeros(len(vertices), bool)
    used[triangles.ravel()] = True
    remap = np.cumsum(used) - 1
    return SurfaceMesh(vertices[used], remap[triangles])


def _remove_degenerate(surface: SurfaceMesh, changes: list[str]) -> SurfaceMesh:
    bad = degenerate_triangles(surface)
    if bad.size == 0 or bad.size == surface.triangle_count:
        return surface
    keep = np.ones(surface.triangle_count, bool)
    keep[bad] = False
    candidate = _drop_unused(surface.vertices, surface.triangles[keep])
    if len(boundary_edges(candidate)) > len(boundary_edges(surface)):
        changes.append(f"kept {bad.size} degenerate triangles: removing them would open the surface")
        return surface
    changes.append(f"removed {bad.size} degenerate triangles and {surface.vertex_count - candidate.vertex_count} "
                   f"vertices left unused")
    return candidate


def _face_neighbours(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Across each manifold edge (exactly two triangles): ``(pairs (k, 2) face indices, same (k,) bool)`` where
    ``same`` is True when both faces walk the edge in the same direction (one of them must be flipped)."""
    m = len(triangles)
    directed = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64)
    face = np.repeat(np.arange(m), 3)
    low, high = directed.min(axis=1), directed.max(axis=1)
    forward = directed[:, 0] < directed[:, 1]
    key = low * (int(high.max()) + 1) + high
    order = np.argsort(key, kind="stable")
    key, face, forward = key[order], face[order], forward[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    size = np.diff(np.r_[start, len(key)])
    two = start[size == 2]
    pairs = np.stack([face[two], face[two + 1]], axis=1)
    return pairs, forward[two] == forward[two + 1]


def _orient(surface: SurfaceMesh, changes: list[str]) -> SurfaceMesh:
    triangles = surface.triangles.copy()
    if len(inconsistent_edges(surface)):
        pairs, same = _face_neighbours(triangles)
        m = len(triangles)
        adjacency = [[] for _ in range(m)]
        for (a, b), s in zip(pairs.tolist(), same.tolist()):
            adjacency[a].append((b, s))
            adjacency[b].append((a, s))
        flip = np.full(m, -1, np.int8)  # -1 unvisited, 0 keep, 1 flip
        piece = np.zeros(m, np.int64)
        conflicts = 0
        for seed in range(m):
            if flip[seed] >= 0:
                continue
            flip[seed] = 0
            piece[seed] = seed
            queue = deque([seed])
            while queue:
                a = queue.popleft()
                for b, s in adjacency[a]:
                    # Same direction on the shared edge means opposite orientations: b's flip differs from a's.
                    want = flip[a] ^ int(s)
                    if flip[b] < 0:
                        flip[b] = want
                        piece[b] = piece[seed]
                        queue.append(b)
                    elif flip[b] != want:
                        conflicts += 1
        if conflicts:
            changes.append("could not make the orientation consistent: the surface is not orientable "
                           f"({conflicts} conflicting edges, e.g. a Moebius band or non-manifold edges)")
            return surface
        # Keep each piece's majority orientation (fewer faces change); the inward check below settles the sign.
        flipped_per_piece = np.bincount(piece, weights=flip, minlength=m)
        size_per_piece = np.bincount(piece, minlength=m)
        flip = np.where(flipped_per_piece[piece] > size_per_piece[piece] / 2, 1 - flip, flip)
        flipped = np.flatnonzero(flip == 1)
        triangles[flipped] = triangles[flipped][:, ::-1]
        changes.append(f"reoriented {flipped.size} triangles to make the orientation consistent")
        surface = SurfaceMesh(surface.vertices, triangles)
    if len(boundary_edges(surface)) == 0 and faces_inward(surface):
        volume = surface.signed_volume
        surface = SurfaceMesh(surface.vertices, surface.triangles[:, ::-1])
        changes.append(f"reversed all {surface.triangle_count} triangles: the faces pointed inward "
                       f"(signed volume {volume:.4g} m³ -> {surface.signed_volume:.4g} m³)")
    return surface


def _meshfix(surface: SurfaceMesh, crossings: int, changes: list[str]) -> SurfaceMesh:
    try:
        import pymeshfix
    except ImportError as exc:
        raise MeshError(f"{crossings} self-intersecting triangle pairs need pymeshfix to repair; "
                        "pip install tissuesim[repair] (or fix the mesh in MeshLab or Blender)") from exc
    fixer = pymeshfix.MeshFix(surface.vertices, surface.triangles.astype(np.int32))
    fixer.repair()
    vertices, triangles = np.asarray(fixer.points, np.float64), np.asarray(fixer.faces, np.int64)
    if len(triangles) == 0:
        raise MeshError(f"pymeshfix could not repair the {crossings} self-intersecting triangle pairs (it removed "
                        "every triangle); fix the mesh in MeshLab or Blender")
    repaired = SurfaceMesh(vertices, triangles)
    changes.append(f"removed {crossings} self-intersecting triangle pairs with pymeshfix: vertices "
                   f"{surface.vertex_count} -> {repaired.vertex_count}, triangles {surface.triangle_count} -> "
                   f"{repaired.triangle_count} (vertices are renumbered)")
    return repaired
