"""Local refinement of a closed triangle surface by conforming longest-edge bisection, geometry unchanged.

Used by the contact reference (:mod:`tissuesim.experiments.reference`): the fine FEM reference needs a mesh much
finer than M_S near the contact, yet every M_S vertex must stay a node so the sampled displacements are nodal values.
Each pass marks the triangles whose longest edge exceeds a target size at its midpoint, splits those longest edges
at their midpoints, and closes the marking (a triangle with any split edge has its longest edge split too), so every
subdivided triangle is bisected through its longest edge first. That is Rivara's rule, which keeps the smallest angle
bounded below by a fixed fraction of the input's, and it leaves no hanging vertex: the result is again a closed,
consistently oriented manifold. On flat regions new vertices are the midpoints of existing edges, so the surface is
the same set of points; on curved regions they lie on a smooth curve through the edge's ends (see
:func:`_edge_midpoints`), within |e|²/(8ρ) of the facet (0.1 mm for a 6 mm edge on a 40 mm radius). Input vertices
keep their indices and coordinates bit for bit (new ones are appended).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import MeshError
from .surface import SurfaceMesh

# Edges whose end normals differ by more than this are creases (the cube's edges): split at the plain midpoint.
SHARP_DEGREES = 30.0
# A pass can at most halve an edge; this many passes shrink any edge by 2**-MAX_PASSES, far below any sensible size.
MAX_PASSES = 40

__all__ = ["refine_surface"]


def refine_surface(surface: SurfaceMesh, size: Callable[[np.ndarray], np.ndarray], *,
                   parents: bool = False) -> SurfaceMesh | tuple[SurfaceMesh, np.ndarray]:
    """The surface refined until no triangle's longest edge exceeds ``size`` at that edge's midpoint.

    Args:
        surface: a closed surface (every edge shared by exactly two triangles).
        size: target edge length [m] as a function of points ``(k, 3)`` [m] → ``(k,)`` positive lengths.
        parents: also return the edge each new vertex splits.

    Returns:
        A new :class:`SurfaceMesh` whose first ``surface.vertex_count`` vertices are ``surface.vertices`` unchanged;
        with ``parents``, also ``(k, 2) int64``: the two vertices of the edge split by each of the k new vertices,
        in order (each created before it), so a field linear over the input's triangles is carried to the new
        vertices by averaging.
    """
    vertices = np.array(surface.vertices, dtype=np.float64)
    triangles = np.array(surface.triangles, dtype=np.int64)
    split_edges = [np.zeros((0, 2), dtype=np.int64)]
    for _ in range(MAX_PASSES):
        edges, tri_edges = _edges(triangles)
        lengths = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
        longest = np.argmax(lengths[tri_edges], axis=1)  # local index 0..2 of each triangle's longest edge
        longest_edge = tri_edges[np.arange(len(triangles)), longest]
        midpoints = _edge_midpoints(vertices, triangles, edges)
        target = np.asarray(size(midpoints[longest_edge]), dtype=np.float64)
        if target.shape != (len(triangles),) or not np.all(target > 0):
            raise MeshError("refine_surface: size() must return one positive length per point")
        split = np.zeros(len(edges), dtype=bool)
        split[longest_edge[lengths[longest_edge] > target]] = True
        if not split.any():
            mesh = SurfaceMesh(vertices, triangles.astype(np.int32))
            return (mesh, np.concatenate(split_edges).astype(np.int64)) if parents else mesh
        _close_marking(split, tri_edges, longest_edge)
        new_index = np.full(len(edges), -1, dtype=np.int64)
        new_index[split] = len(vertices) + np.arange(int(split.sum()))
        split_edges.append(edges[split])
        vertices = np.concatenate([vertices, midpoints[split]])
        triangles = _subdivide(triangles, tri_edges, longest, new_index)
    raise MeshError(f"refine_surface did not reach the target size in {MAX_PASSES} passes; is size() too small?")


def _edge_midpoints(vertices, triangles, edges) -> np.ndarray:
    """``(e, 3)`` the point that splits each edge: the midpoint of the cubic Hermite curve whose end tangents are the
    edge projected onto the end vertices' tangent planes (area-weighted vertex normals). On a flat region that is the
    edge's midpoint exactly; on a curved one it lies on the smooth surface through the vertices (on a sphere of radius
    ρ, |e|²/(8ρ) outside the chord) instead of on the flat facet, which TetGen cannot tetrahedralize once many nearly
    coplanar slivers of one facet meet (measured: it fails from the third level on the sphere and the steak). Where
    the end normals differ by more than :data:`SHARP_DEGREES` the edge crosses a crease: the plain midpoint keeps
    the crease sharp."""
    p0, p1 = vertices[edges[:, 0]], vertices[edges[:, 1]]
    normals = _vertex_normals(vertices, triangles)
    n0, n1 = normals[edges[:, 0]], normals[edges[:, 1]]
    d = p1 - p0
    bulge = (np.einsum("ij,ij->i", d, n1)[:, None] * n1 - np.einsum("ij,ij->i", d, n0)[:, None] * n0) / 8.0
    smooth = np.einsum("ij,ij->i", n0, n1) >= np.cos(np.radians(SHARP_DEGREES))
    return 0.5 * (p0 + p1) + np.where(smooth[:, None], bulge, 0.0)


def _vertex_normals(vertices, triangles) -> np.ndarray:
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    face = np.cross(b - a, c - a)  # length: twice the area, so the sum is area-weighted
    normals = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(normals, triangles[:, k], face)
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)


def _edges(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique edges ``(e, 2)`` and each triangle's edge ids ``(m, 3)``; local edge j joins corners j and j+1."""
    pairs = np.stack([triangles, np.roll(triangles, -1, axis=1)], axis=2).reshape(-1, 2)
    edges, inverse = np.unique(np.sort(pairs, axis=1), axis=0, return_inverse=True)
    return edges, inverse.reshape(-1, 3)


def _close_marking(split: np.ndarray, tri_edges: np.ndarray, longest_edge: np.ndarray) -> None:
    """Mark the longest edge of every triangle that has a marked edge, until nothing changes (in place)."""
    while True:
        touched = split[tri_edges].any(axis=1)
        missing = touched & ~split[longest_edge]
        if not missing.any():
            return
        split[longest_edge[missing]] = True


def _subdivide(triangles, tri_edges, longest, new_index) -> np.ndarray:
    """Split each triangle by its marked edges, longest first, keeping the orientation."""
    m = len(triangles)
    rows = np.arange(m)[:, None]
    order = (longest[:, None] + np.arange(3)) % 3  # rotate so the longest edge is local edge 0 (corners a, b)
    a, b, c = (triangles[rows, order][:, k] for k in range(3))
    e = tri_edges[rows, order]
    m_ab, m_bc, m_ca = new_index[e[:, 0]], new_index[e[:, 1]], new_index[e[:, 2]]
    s_ab, s_bc, s_ca = m_ab >= 0, m_bc >= 0, m_ca >= 0
    pieces = [np.stack([a, b, c], axis=1)[~s_ab]]
    one = s_ab & ~s_bc & ~s_ca
    pieces += [np.stack([a, m_ab, c], 1)[one], np.stack([m_ab, b, c], 1)[one]]
    bc = s_ab & s_bc & ~s_ca
    pieces += [np.stack([a, m_ab, c], 1)[bc], np.stack([m_ab, b, m_bc], 1)[bc], np.stack([m_ab, m_bc, c], 1)[bc]]
    ca = s_ab & ~s_bc & s_ca
    pieces += [np.stack([a, m_ab, m_ca], 1)[ca], np.stack([m_ca, m_ab, c], 1)[ca], np.stack([m_ab, b, c], 1)[ca]]
    red = s_ab & s_bc & s_ca
    pieces += [np.stack([a, m_ab, m_ca], 1)[red], np.stack([m_ab, b, m_bc], 1)[red],
               np.stack([m_ca, m_bc, c], 1)[red], np.stack([m_ab, m_bc, m_ca], 1)[red]]
    return np.concatenate(pieces)
