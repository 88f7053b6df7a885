"""How the simulator draws M_S: tissue by default, the displacement colour map as an option with its legend.

Polyscope shades a surface smooth (one normal per vertex, averaged over its triangles) or flat (one per triangle).
Smooth shading averages across a sharp edge, such as the cube's: the normals at the edge's vertices point half-way,
and the edge is drawn as a ragged band whose teeth follow the triangulation. :func:`crease_split` gives every vertex
on a crease one drawn copy per smooth side (split normals): the drawn surface is smooth within each side and sharp
across the crease, and a smooth organ is drawn as it is. The split is computed at rest, once per topology (a cut),
and each frame only gathers the positions (:class:`TissueSurface`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from types import ModuleType

#: The drawn surface's name; not "M_S": polyscope keeps a structure's options (material, back faces) by name, and
#: the figures draw their own "M_S".
SURFACE = "tissue"
#: Tissue: a deep red that polyscope's wax material lightens to the pink-red of serosa [RGB, 0..1].
TISSUE_COLOR = (0.48, 0.11, 0.11)
#: Polyscope's wax material: a soft specular highlight over a diffuse base, as moist tissue shows.
TISSUE_MATERIAL = "wax"
#: The surface is drawn opaque. Polyscope's one-pass ("simple") transparency stops hiding what lies behind the
#: surface (the wound's walls showed through it even at opacity 1), and its depth peeling ("pretty") took 479 instead
#: of 65 ms per frame on Mesa's software renderer (liver, the wound, benchmarks/viewer_screenshots.py): a translucent
#: look is not worth either.
#: Two triangles sharing an edge are shaded as one smooth surface when their normals differ by less than this [deg];
#: the cube's edges (90°) stay sharp, a remeshed organ's neighbours (well under 30°) stay smooth.
CREASE_DEGREES = 50.0
COLOUR_MAP = "viridis"
COLOUR_NAME = "|u| [mm]"
#: Where the colour map's legend sits: pixels from the window's top left (the panel is on the right).
LEGEND_AT = (20.0, 20.0)


def crease_split(vertices: np.ndarray, triangles: np.ndarray, *,
                 degrees: float = CREASE_DEGREES) -> tuple[np.ndarray, np.ndarray]:
    """Split normals along the creases of a triangle surface.

    Args:
        vertices: ``(n, 3) float64`` positions [m] (at rest: the creases of the model, not of a deformation).
        triangles: ``(m, 3) int`` vertex indices.
        degrees: the angle between two neighbouring triangles' normals above which their edge is a crease.

    Returns:
        ``(source, faces)``: ``source`` ``(r,) int64`` the vertex of ``vertices`` each drawn vertex copies (r ≥ n
        where a vertex lies on a crease; unused vertices are dropped), and ``faces`` ``(m, 3) int64`` the triangles
        over the drawn vertices. Corners of one vertex join when their triangles meet across a smooth edge.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    tri = np.asarray(triangles, dtype=np.int64)
    m, n = len(tri), len(vertices)
    p = np.asarray(vertices, dtype=np.float64)[tri]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), np.finfo(float).tiny)
    # half-edge h = 3 f + k runs from corner 3 f + k to corner 3 f + (k + 1) % 3
    start = tri.ravel()
    end = tri[:, [1, 2, 0]].ravel()
    corner = np.arange(3 * m)
    next_corner = 3 * (corner // 3) + (corner + 1) % 3
    key = start * n + end
    order = np.argsort(key)
    twin_at = np.searchsorted(key[order], end * n + start).clip(max=3 * m - 1)
    twin = order[twin_at]
    paired = key[twin] == end * n + start              # a border (a cut's lip) has no twin: its corners stay apart
    smooth = paired & (np.einsum("hd,hd->h", normal[corner // 3], normal[twin // 3]) >
                       np.cos(np.radians(degrees)))
    # the start corner of h and the end corner of its twin are one vertex seen from the two triangles
    links = coo_matrix((np.ones(int(smooth.sum())), (corner[smooth], next_corner[twin[smooth]])), shape=(3 * m, 3 * m))
    _, label = connected_components(links, directed=False)
    source = np.empty(label.max() + 1, dtype=np.int64)
    source[label] = start
    return source, label.reshape(m, 3).astype(np.int64)


class TissueSurface:
    """M_S as polyscope draws it: tissue-coloured, split along creases, the |u| colour map on demand.

    Args:
        ps: the polyscope module. positions: ``(n, 3) float64`` current positions [m]. triangles: ``(m, 3) int``.
        rest: ``(n, 3) float64`` rest positions [m] (where the creases are found).
    """

    def __init__(self, ps: ModuleType, positions: np.ndarray, triangles: np.ndarray, rest: np.ndarray):
        self.source, faces = crease_split(rest, triangles)
        self.mesh = ps.register_surface_mesh(SURFACE, np.asarray(positions)[self.source], faces, smooth_shade=True,
                                             color=TISSUE_COLOR, material=TISSUE_MATERIAL, back_face_policy="different")
        self.colours = False

    def update(self, positions: np.ndarray) -> None:
        """Move the drawn vertices to ``positions`` ``(n, 3)`` [m]."""
        self.mesh.update_vertex_positions(np.asarray(positions)[self.source])

    def colour(self, millimetres: np.ndarray | None, top: float) -> None:
        """Show ``millimetres`` ``(n,) float64`` (|u| [mm]) in the colour map from 0 to ``top`` [mm], with its
        legend on screen; None: back to tissue."""
        if millimetres is None:
            if self.colours:
                self.mesh.remove_all_quantities()
                self.colours = False
            return
        self.mesh.add_scalar_quantity(COLOUR_NAME, np.asarray(millimetres)[self.source], enabled=True, cmap=COLOUR_MAP,
                                      vminmax=(0.0, top), onscreen_colorbar_enabled=True,
                                      onscreen_colorbar_location=LEGEND_AT)
        self.colours = True
