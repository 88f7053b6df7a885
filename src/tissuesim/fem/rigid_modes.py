"""Whether supports hold a body: the rigid motions (3 translations, 3 rotations ω × x) that a set of held points
leaves free. A volume's fixed dofs and the surface methods' fixed vertices and elastic attachments are checked by
the same count, so every method refuses the same supports, up front."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph

#: A rigid mode is free when the Gram matrix of the six modes restricted to the held dofs has an eigenvalue below
#: this fraction of its largest (collinear held points give ~1e-16).
RIGID_MODE_TOLERANCE = 1e-10


def rigid_modes(points: np.ndarray, centre: np.ndarray, scale: float) -> np.ndarray:
    """``(k, 3, 6) float64``: the six rigid modes at ``points`` ``(k, 3)`` [m], rotations about ``centre`` ``(3,)``
    [m] with lever arms divided by ``scale`` [m] (so translations and rotations weigh alike)."""
    x = (np.asarray(points, dtype=np.float64) - centre) / scale
    modes = np.zeros((len(x), 3, 6))
    modes[:, [0, 1, 2], [0, 1, 2]] = 1.0
    xs, ys, zs = x[:, 0], x[:, 1], x[:, 2]
    modes[:, 1, 3], modes[:, 2, 3] = -zs, ys  # rotation about x
    modes[:, 0, 4], modes[:, 2, 4] = zs, -xs  # rotation about y
    modes[:, 0, 5], modes[:, 1, 5] = -ys, xs  # rotation about z
    return modes


def free_rigid_modes(piece: np.ndarray, held: np.ndarray, held_axes: np.ndarray | None = None) -> int:
    """How many of the six rigid motions of a body whose points are ``piece`` ``(m, 3)`` [m] remain free when the
    points ``held`` ``(k, 3)`` [m] are held: along every axis, or only along ``held_axes`` ``(k,) int`` (0, 1, 2:
    a roller). 6 when nothing is held, 3 for one point, 1 for points on one line, 0 for three non-collinear ones."""
    held = np.asarray(held, dtype=np.float64).reshape(-1, 3)
    if held.size == 0:
        return 6
    piece = np.asarray(piece, dtype=np.float64)
    scale = float(np.linalg.norm(np.ptp(piece, axis=0))) or 1.0
    modes = rigid_modes(held, piece.mean(axis=0), scale)
    restricted = modes.reshape(-1, 6) if held_axes is None else modes[np.arange(len(held)), held_axes]
    eigenvalues = np.linalg.eigvalsh(restricted.T @ restricted)
    return int(np.sum(eigenvalues <= RIGID_MODE_TOLERANCE * eigenvalues[-1]))


def connected_pieces(elements: np.ndarray, node_count: int) -> tuple[int, np.ndarray]:
    """``(count, labels (node_count,) int32)``: the connected pieces of a mesh whose ``elements`` ``(m, k) int``
    (triangles, tets) join their nodes; a node in no element is a piece of its own."""
    elements = np.asarray(elements, dtype=np.int64)
    chain = sp.coo_matrix((np.ones(elements[:, 1:].size), (elements[:, :-1].ravel(), elements[:, 1:].ravel())),
                          shape=(node_count, node_count))       # edges 0-1, 1-2, ... join every element
    return csgraph.connected_components(chain, directed=False)
