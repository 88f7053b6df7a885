"""The walls of a wound, to draw: from each lip of a cut down to the blade's depth, so an opened cut looks like an
opening in tissue and not a crack in a sheet (the surface M_S has no thickness to show).

:func:`wound_walls` is a pure function of the current positions, cheap enough for every frame (one vectorised pass
over the triangles, then work on the wound's own edges). Each border edge of the cut (an edge with one triangle
that touches a duplicated vertex) gets a quad hanging from it; the two copies of one cut vertex share the quad's
bottom corner, at the blade's depth under their midpoint along their mean inward normal, so the walls of the two
lips meet at the wound's floor (a V that closes flat when the wound closes). A tip of the cut (a cut vertex with no
copy) is its own bottom, so the walls taper to the wound's ends. The walls face into the wound.
"""

from __future__ import annotations

import numpy as np


def wound_walls(positions: np.ndarray, triangles: np.ndarray, pairs: np.ndarray,
                depth: float) -> tuple[np.ndarray, np.ndarray]:
    """The wall mesh of the wound.

    Args:
        positions: ``(n, 3) float64`` current positions of the surface [m].
        triangles: ``(m, 3) int`` its triangles, counter-clockwise from outside.
        pairs: ``(r, 2) int`` the duplicated vertex pairs (the two lips of each cut vertex: vertices that share a
            rest position, e.g. :func:`tissuesim.mesh.coincident.coincident_pairs` of the rest positions, found once
            per cut); the first of a pair is its group's key (a vertex cut twice has several pairs with one key).
        depth: the blade's depth [m] (≥ 0): how far the walls reach below the lips.

    Returns:
        ``(points (p, 3) float64 [m], faces (q, 3) int32)``: the lips, then the bottom corners; empty for an uncut
        surface.
    """
    positions = np.asarray(positions, dtype=np.float64)
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if not len(pairs):
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int32)
    triangles = np.asarray(triangles, dtype=np.int64)
    cut = np.zeros(len(positions), dtype=bool)
    cut[pairs.ravel()] = True
    rows = triangles[cut[triangles].any(axis=1)]                  # every triangle of a wound edge
    edges = _border_edges(rows, cut)
    lips = np.unique(edges)
    slot = np.full(len(positions), -1, dtype=np.int64)
    slot[lips] = np.arange(len(lips))
    inward = -_vertex_normals(positions, rows, slot, len(lips))
    # each lip's group: the key of its pairs (a tip of the cut is its own group, with no depth)
    group = lips.copy()
    held = slot[pairs[:, 1]] >= 0
    group[slot[pairs[held, 1]]] = pairs[held, 0]
    keys, member = np.unique(group, return_inverse=True)
    count = np.bincount(member, minlength=len(keys))[:, None]
    middle = np.zeros((len(keys), 3))
    np.add.at(middle, member, positions[lips])
    down = np.zeros((len(keys), 3))
    np.add.at(down, member, inward)
    length = np.linalg.norm(down, axis=1, keepdims=True)
    down = np.divide(down, length, out=np.zeros_like(down), where=length > 0.0)
    bottom = middle / count + depth * np.where(count > 1, 1.0, 0.0) * down
    points = np.concatenate([positions[lips], bottom])
    top = slot[edges]                                              # (e, 2) lips a → b, the tissue on the left
    low = len(lips) + member[top]
    faces = np.concatenate([np.stack([top[:, 0], low[:, 0], top[:, 1]], axis=1),
                            np.stack([top[:, 1], low[:, 0], low[:, 1]], axis=1)])
    # a tip's bottom is the tip: drop the triangles that collapse there
    keep = np.linalg.norm(np.cross(points[faces[:, 1]] - points[faces[:, 0]],
                                   points[faces[:, 2]] - points[faces[:, 0]]), axis=1) > 0.0
    return points, faces[keep].astype(np.int32)


def _border_edges(rows: np.ndarray, cut: np.ndarray) -> np.ndarray:
    """``(e, 2) int64`` directed edges (a, b) of ``rows`` ``(k, 3)`` (in their winding) that no other row holds
    reversed, and that touch a vertex where ``cut`` is set."""
    directed = rows[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    code = directed[:, 0] << 32 | directed[:, 1]
    reverse = directed[:, 1] << 32 | directed[:, 0]
    border = ~np.isin(code, reverse)
    border &= cut[directed[:, 0]] | cut[directed[:, 1]]
    return directed[border]


def _vertex_normals(positions, rows, slot, count) -> np.ndarray:
    """``(count, 3)`` unit area-weighted normals at the vertices with a ``slot``, from the triangles ``rows``."""
    p = positions[rows]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    out = np.zeros((count, 3))
    for corner in range(3):
        at = slot[rows[:, corner]]
        np.add.at(out, at[at >= 0], normal[at >= 0])
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, length, out=np.zeros_like(out), where=length > 0.0)
