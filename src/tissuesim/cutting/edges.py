"""Edges of triangle rows as ``(lo, hi)`` vertex pairs: which rows hold given edges (read from the vertex fans),
and every edge of a set of changed rows. Both pack an edge as one int64 code, ``lo << 32 | hi``, and sort."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from .fans import VertexFans


def edge_key(u: int, v: int) -> tuple[int, int]:
    """The edge (u, v) as ``(lo, hi)`` ints."""
    u, v = int(u), int(v)
    return (u, v) if u < v else (v, u)


def edge_owners(fans: VertexFans, triangles: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """``(k, 2) int64`` the rows of ``triangles`` holding each edge of ``keys`` ``(k, 2) int`` (lo < hi), ascending;
    −1 where an edge has fewer (a border edge has one, a removed edge none). One vectorised pass over the rows
    holding their vertices: no table of every edge is kept (a Python dict of the whole mesh's edges slows every
    garbage collection)."""
    keys = np.asarray(keys, dtype=np.int64).reshape(-1, 2)
    owners = np.full((len(keys), 2), -1, dtype=np.int64)
    if not len(keys):
        return owners
    rows = fans.rows_holding(np.unique(keys), triangles)
    corners = triangles[rows].astype(np.int64)
    following = np.roll(corners, -1, axis=1)
    code = ((np.minimum(corners, following) << 32) | np.maximum(corners, following)).ravel()
    order = np.argsort(code, kind="stable")
    code, owner = code[order], np.repeat(rows, 3)[order]
    wanted = (keys[:, 0] << 32) | keys[:, 1]
    first, last = np.searchsorted(code, wanted, side="left"), np.searchsorted(code, wanted, side="right")
    for j in range(2):       # an edge has at most two triangles (the cut keeps the surface manifold)
        has = last - first > j
        owners[has, j] = owner[first[has] + j]
    return owners


def touched_edges(old_content: ArrayLike, new_content: ArrayLike) -> np.ndarray:
    """``(k, 2) int64`` every edge (lo < hi, ascending) of the old and new content of the changed triangles."""
    content = np.concatenate([np.asarray(old_content, dtype=np.int64).reshape(-1, 3),
                              np.asarray(new_content, dtype=np.int64).reshape(-1, 3)])
    following = np.roll(content, -1, axis=1)
    code = np.unique(((np.minimum(content, following) << 32) | np.maximum(content, following)).ravel())
    return np.stack([code >> 32, code & 0xFFFFFFFF], axis=1)
