"""The hybrid mesh of §5: fine surface M_S, coarse surface M'_S, coarse volume M_V, and the maps between them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .surface import SurfaceMesh
from .tetmesh import TetMesh


@dataclass(frozen=True, eq=False)
class HybridMesh:
    """Static data of the hybrid model. Build with :meth:`HybridMesh.build`; save/load with :meth:`save`/:meth:`load`.

    Attributes:
        surface: M_S, the fine triangle surface that is rendered and cut; ``n_s`` vertices [m].
        coarse_surface: M'_S, the simplified surface; its vertices are ``surface.vertices[control]`` in that order,
            its triangles index them (``(t, 3) int32``).
        volume: M_V, TetGen's tetrahedralization of M'_S; its boundary nodes are exactly the control nodes.
        control: ``(c,) int32`` M_S vertex indices of the control nodes (§6), sorted ascending.
        control_volume: ``(c,) int32`` M_V node index of each control node:
            ``volume.points[control_volume] == surface.vertices[control]`` bit for bit.
        coarse_triangle: ``(n_s,) int32`` for every M_S vertex, the M'_S triangle under it (closest point),
            used to split a load on that vertex over three control nodes (§6.1).
        coarse_barycentric: ``(n_s, 3) float64`` barycentric weights of that closest point in its M'_S triangle;
            non-negative, summing to 1; a control node has weight 1 on itself.
        embedding_tet: ``(n_s,) int32`` the M_V tet containing each M_S vertex (or the nearest one when the vertex
            lies outside M_V), for the embedded-surface baseline.
        embedding_barycentric: ``(n_s, 4) float64`` barycentric coordinates of each M_S vertex in that tet; they
            sum to 1 and reproduce the vertex exactly (they may be slightly negative for a vertex outside M_V).
        fine_volume: the paper's fine volume mesh, TetGen's tetrahedralization of M_S itself, or None if not built.
        fine_surface_nodes: ``(n_s,) int32`` fine-volume node index of every M_S vertex (identical coordinates), or
            None with ``fine_volume``.
        info: build report (simplification rounds, collapses skipped, TetGen switches, timings).
    """

    surface: SurfaceMesh
    coarse_surface: SurfaceMesh
    volume: TetMesh
    control: np.ndarray
    control_volume: np.ndarray
    coarse_triangle: np.ndarray
    coarse_barycentric: np.ndarray
    embedding_tet: np.ndarray
    embedding_barycentric: np.ndarray
    fine_volume: TetMesh | None = None
    fine_surface_nodes: np.ndarray | None = None
    info: dict = field(default_factory=dict)
