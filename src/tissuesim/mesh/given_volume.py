"""A coarse volume M_V from a mesher of the user's choice (:meth:`HybridMesh.from_volume
<tissuesim.mesh.hybrid.HybridMesh.from_volume>`): checked against M_S, and M'_S read off its boundary.

TetGen (AGPL-3.0) makes M_V in :meth:`HybridMesh.build <tissuesim.mesh.hybrid.HybridMesh.build>`; a product that
cannot ship it brings its own tets. §5's structure must hold for them: M'_S is M_V's boundary, and its vertices are a
subset of M_S's (the control nodes), so every boundary node of the volume must be a vertex of M_S (no Steiner point
on the boundary; interior nodes are free), each a different one, and the boundary must be a closed, manifold,
outward surface (:func:`~.validate.validate_surface`).
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshError, first_indices
from .surface import SurfaceMesh
from .tetmesh import TetMesh

#: A boundary node counts as an M_S vertex within this fraction of M_S's mean edge length.
MATCH_FRACTION = 1e-6


def coarse_from_volume(surface: SurfaceMesh, volume: TetMesh) -> tuple[SurfaceMesh, np.ndarray, np.ndarray]:
    """``(coarse, control, control_volume)``: M'_S (the volume's boundary, its vertices the control nodes in
    ascending M_S order), ``control`` ``(c,) int32`` the M_S vertex of each, ``control_volume`` ``(c,) int32`` the
    volume node of each. Raises MeshError naming the first boundary nodes that are no M_S vertex, or that share
    one."""
    from scipy.spatial import cKDTree

    if not isinstance(volume, TetMesh):
        raise MeshError(f"the coarse volume must be a TetMesh (tissuesim.mesh.tetmesh.TetMesh(points, tets), tets "
                        f"positively oriented), got {type(volume).__name__}")
    boundary = volume.boundary_nodes
    distance, vertex = cKDTree(surface.vertices).query(volume.points[boundary])
    off = np.flatnonzero(distance > MATCH_FRACTION * surface.mean_edge_length)
    if off.size:
        raise MeshError(
            f"{off.size} of the volume's {boundary.size} boundary nodes are no vertex of M_S (first nodes: "
            f"{first_indices(boundary[off])}, up to {distance[off].max():.3g} m away): M_V's boundary must be made "
            "of M_S's own vertices (§5: M'_S's vertices are a subset of M_S's); mesh the coarse surface without "
            "boundary Steiner points (TetGen's Y switch, gmsh's Mesh.MeshSizeExtendFromBoundary with the surface "
            "kept), or let HybridMesh.build make M_V")
    order = np.argsort(vertex, kind="stable")
    control = vertex[order]
    shared = np.flatnonzero(np.diff(control) == 0)
    if shared.size:
        raise MeshError(f"{shared.size} M_S vertices carry two boundary nodes of the volume (first vertices: "
                        f"{first_indices(control[shared])}): merge the volume's duplicate nodes")
    control_volume = boundary[order]
    place = np.full(volume.node_count, -1, dtype=np.int64)
    place[control_volume] = np.arange(control.size)
    triangles = place[volume.boundary_triangles]
    coarse = SurfaceMesh(np.array(surface.vertices[control]), triangles.astype(np.int32))
    return coarse, control.astype(np.int32), control_volume.astype(np.int32)
