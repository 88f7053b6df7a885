"""Triangle surface meshes: the fine surface M_S and the coarse surface M'_S of the paper (§5)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import MeshError, first_indices


@dataclass(frozen=True, eq=False)
class SurfaceMesh:
    """A triangle surface.

    Attributes:
        vertices: ``(n, 3) float64`` vertex positions [m].
        triangles: ``(m, 3) int32`` vertex indices per triangle; counter-clockwise seen from outside, so normals
            point outward on a valid closed surface.

    Construction checks only array shapes and index ranges; geometric and topological checks (closed, manifold,
    oriented, self-intersection free) live in :mod:`tissuesim.mesh.validate`.
    """

    vertices: np.ndarray
    triangles: np.ndarray

    def __post_init__(self):
        vertices = np.ascontiguousarray(self.vertices, dtype=np.float64)
        triangles = np.ascontiguousarray(self.triangles, dtype=np.int32)
        if vertices.ndim != 2 or vertices.shape[1] != 3:
            raise MeshError(f"vertices must have shape (n, 3), got {vertices.shape}")
        if triangles.ndim != 2 or triangles.shape[1] != 3:
            raise MeshError(f"triangles must have shape (m, 3), got {triangles.shape}")
        if not np.all(np.isfinite(vertices)):
            bad = np.flatnonzero(~np.all(np.isfinite(vertices), axis=1))
            raise MeshError(f"{bad.size} vertices have non-finite coordinates (first: {first_indices(bad)})")
        out = np.flatnonzero(np.any((triangles < 0) | (triangles >= len(vertices)), axis=1))
        if out.size:
            raise MeshError(
                f"{out.size} triangles reference vertices outside 0..{len(vertices) - 1} "
                f"(first triangles: {first_indices(out)})"
            )
        vertices.flags.writeable = False
        triangles.flags.writeable = False
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "triangles", triangles)

    @classmethod
    def trusted(cls, vertices: np.ndarray, triangles: np.ndarray) -> "SurfaceMesh":
        """A mesh of arrays known to be valid (``(n, 3) float64`` and ``(m, 3) int32``, C-contiguous, indices in
        range), made without the O(n + m) checks and without copying: for code that keeps these invariants itself
        (a cut, :mod:`tissuesim.cutting`). The arrays are made read-only."""
        mesh = object.__new__(cls)
        vertices.flags.writeable = False
        triangles.flags.writeable = False
        object.__setattr__(mesh, "vertices", vertices)
        object.__setattr__(mesh, "triangles", triangles)
        return mesh

    @property
    def vertex_count(self) -> int:
        return len(self.vertices)

    @property
    def triangle_count(self) -> int:
        return len(self.triangles)

    @cached_property
    def edges(self) -> np.ndarray:
        """``(e, 2) int32`` unique undirected edges, each sorted ``(low, high)``, in lexicographic order."""
        directed = self.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        return np.unique(np.sort(directed, axis=1), axis=0).astype(np.int32)

    @cached_property
    def mean_edge_length(self) -> float:
        """Mean length of the edges [m]."""
        e = self.edges
        return float(np.linalg.norm(self.vertices[e[:, 0]] - self.vertices[e[:, 1]], axis=1).mean())

    @cached_property
    def triangle_normals(self) -> np.ndarray:
        """``(m, 3) float64`` unit normals (right-hand rule on the vertex order); zero for degenerate triangles."""
        p = self.vertices[self.triangles]
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        return np.divide(n, length, out=np.zeros_like(n), where=length > 0)

    @cached_property
    def triangle_areas(self) -> np.ndarray:
        """``(m,) float64`` triangle areas [m²]."""
        p = self.vertices[self.triangles]
        return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)

    @cached_property
    def signed_volume(self) -> float:
        """Enclosed volume [m³] by the divergence theorem; negative when the faces point inward."""
        p = self.vertices[self.triangles]
        return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)

    @property
    def bounds(self) -> np.ndarray:
        """``(2, 3) float64`` axis-aligned bounding box ``[min, max]`` [m]."""
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    def with_vertices(self, vertices: np.ndarray) -> "SurfaceMesh":
        """The same connectivity at new positions ``(n, 3)`` [m]."""
        return SurfaceMesh(vertices, self.triangles)
