"""§7: duplicate the vertices along a cut, one copy per side, so the wound can open.

Around each vertex v on a cut edge, v's triangles are grouped into wedges: two of them belong to the same wedge when
they share an edge (v, x) that is not cut. The first wedge keeps v; every other wedge gets a new copy of v. A cut
that ends inside the surface leaves its tip vertex with one cut edge, so its fan stays one wedge and the tip is not
duplicated: a slit opens between its ends. Cutting a vertex's fan into pieces that only touch at v (a bow tie)
gives each piece its own vertex, so the surface stays vertex-manifold.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from .edges import edge_key

if TYPE_CHECKING:
    from .row_patch import RowPatch


@njit(cache=True)
def rows_touching(triangles: np.ndarray, marked: np.ndarray) -> np.ndarray:
    """``(k,) int64`` rows of ``triangles`` with a corner where ``marked`` ``(n,) bool`` is set (one pass)."""
    keep = np.zeros(triangles.shape[0], dtype=np.bool_)
    for t in range(triangles.shape[0]):
        keep[t] = marked[triangles[t, 0]] or marked[triangles[t, 1]] or marked[triangles[t, 2]]
    return np.flatnonzero(keep)


def separate(patch: RowPatch, cut_edges: Iterable[tuple[int, int]],
             vertex_count: int) -> tuple[np.ndarray, list[tuple[int, int]], np.ndarray]:
    """Duplicate the vertices of ``cut_edges`` (pairs of vertex indices) per wedge, on the rows of ``patch``.

    Args:
        patch: the cut's :class:`~tissuesim.cutting.row_patch.RowPatch`; rows given a copy are rewritten there.
        cut_edges: iterable of ``(u, v)`` vertex pairs; a pair that is not an edge of the patch's rows is ignored.
        vertex_count: the number of vertices so far; copies are numbered from it on.

    Returns:
        ``(copy_of (c,) int64, still_closed list of (u, v), rewritten (r,) int64)``: the vertex each new copy
        duplicates, the cut edges that still have two triangles (the tips of a cut, to be opened by a later cut),
        and the rows given a copy.
    """
    cut = {edge_key(u, v) for u, v in cut_edges}
    if not cut:
        return np.zeros(0, dtype=np.int64), [], np.zeros(0, dtype=np.int64)
    fans = {v: patch.fan(v) for v in sorted({x for edge in cut for x in edge})}
    copies: list[int] = []
    rewritten: list[int] = []

    def base(x):
        """A copy made in this call stands for the vertex it duplicates (its side of a cut edge is cut too)."""
        return copies[x - vertex_count] if x >= vertex_count else int(x)

    for v, fan in fans.items():
        wedges = _wedges(patch, v, fan, cut, base)
        for wedge in wedges[1:]:
            new = vertex_count + len(copies)
            copies.append(v)
            for r in wedge:
                patch.write(r, [new if x == v else x for x in patch.row_list(r)])
            rewritten += wedge
    return (np.array(copies, dtype=np.int64), _still_closed(patch, cut, fans),
            np.unique(np.array(rewritten, dtype=np.int64)))


def _wedges(patch, v, fan, cut, base):
    """Groups of ``fan`` (rows around v) joined across v's uncut edges (union-find over a handful of rows)."""
    parent = {r: r for r in fan}

    def find(r):
        while parent[r] != r:
            parent[r] = parent[parent[r]]
            r = parent[r]
        return r

    by_edge: dict[int, list[int]] = {}
    for r in fan:
        for x in patch.row_list(r):
            if x != v:
                by_edge.setdefault(x, []).append(r)
    for x, rs in by_edge.items():
        if len(rs) == 2 and edge_key(base(v), base(x)) not in cut:
            parent[find(rs[0])] = find(rs[1])
    groups: dict[int, list[int]] = {}
    for r in fan:
        groups.setdefault(find(r), []).append(r)
    return sorted(groups.values(), key=min)


def _still_closed(patch, cut, fans):
    """Cut edges (u, v) still shared by two triangles after the duplication."""
    closed = []
    for u, v in cut:
        rows = [r for r in fans[u] if {u, v} <= set(patch.row_list(r))]
        if len(rows) == 2:
            closed.append((u, v))
    return closed
