"""Vertices that share a position: the two sides of a cut (both copies of a vertex start where it was)."""

from __future__ import annotations

import numpy as np


def coincident_pairs(points: np.ndarray) -> np.ndarray:
    """``(p, 2) int64`` pairs of vertices of ``points`` ``(n, 3)`` at identical positions: (the lowest-numbered
    vertex of the position, another one), in lexicographic order of the position."""
    order = np.lexsort((points[:, 2], points[:, 1], points[:, 0]))  # stable: a position's vertices stay in index order
    ordered = points[order]
    repeat = np.concatenate([[False], np.all(ordered[1:] == ordered[:-1], axis=1)])
    leader = order[np.maximum.accumulate(np.where(repeat, 0, np.arange(len(order))))]
    return np.stack([leader[repeat], order[repeat]], axis=1).astype(np.int64)
