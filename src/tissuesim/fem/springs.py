"""Elastic springs from points of a tet mesh to fixed anchors (ligaments): their stiffness, added to K by
:class:`~.linear.LinearFEM` (option ``springs``), and the check of their arrays."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

from ..errors import BoundaryConditionError, first_indices


def spring_stiffness(n: int, nodes: np.ndarray, weights: np.ndarray, stiffness: np.ndarray) -> sp.csr_matrix:
    """``(3n, 3n)`` CSR Σ_j k_j w_j w_jᵀ ⊗ I₃ [N/m] of springs holding the points Σ_a w_ja u[nodes_ja] (see
    :class:`LinearFEM`'s ``springs``): ``nodes`` ``(p, r) int``, ``weights`` ``(p, r)``, ``stiffness`` ``(p,)``."""
    r = nodes.shape[1]
    a = np.repeat(nodes, r, axis=1)                       # (p, r²) row node, column node
    b = np.tile(nodes, (1, r))
    value = stiffness[:, None] * np.repeat(weights, r, axis=1) * np.tile(weights, (1, r))
    rows = (3 * a[..., None] + np.arange(3)).ravel()
    cols = (3 * b[..., None] + np.arange(3)).ravel()
    return sp.csr_matrix((np.repeat(value.ravel(), 3), (rows, cols)), shape=(3 * n, 3 * n))


def check_springs(springs: tuple[ArrayLike, ArrayLike, ArrayLike] | None,
                  n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(nodes (p, r) int64, weights (p, r), stiffness (p,))`` checked, or None for no spring."""
    if springs is None:
        return None
    nodes, weights, stiffness = (np.asarray(a) for a in springs)
    if nodes.ndim != 2 or nodes.dtype.kind not in "iu" or weights.shape != nodes.shape \
            or stiffness.shape != (len(nodes),):
        raise BoundaryConditionError(f"springs are (nodes (p, r) int, weights (p, r), stiffness (p,) N/m), got "
                                     f"shapes {nodes.shape}, {weights.shape}, {stiffness.shape}")
    if nodes.size and (nodes.min() < 0 or nodes.max() >= n):
        bad = np.flatnonzero(np.any((nodes < 0) | (nodes >= n), axis=1))
        raise BoundaryConditionError(f"{bad.size} springs hold nodes outside 0..{n - 1} (first springs: "
                                     f"{first_indices(bad)})")
    if not (np.all(np.isfinite(weights)) and np.all(np.isfinite(stiffness)) and np.all(stiffness > 0.0)):
        raise BoundaryConditionError("springs need finite weights and positive, finite stiffnesses [N/m]")
    if len(nodes) == 0:
        return None
    return nodes.astype(np.int64), weights.astype(np.float64), stiffness.astype(np.float64)
