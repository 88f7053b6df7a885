"""Rest data of the surface layer measured by the step kernels' own arithmetic (:mod:`.kernels`): edge lengths,
hinge angles and signed hinge angles, so a surface at rest is bitwise at rest for the projections (no spurious force
from a rest value computed another way). Used when the constraints are built and when a cut writes new rows."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .hinge_kernels import TINY_LENGTH, bend_gradient_signed


@njit(cache=True)
def dihedral_angles(positions: np.ndarray, bending: np.ndarray) -> np.ndarray:
    """``(b,) float64`` θ of eq 10 [rad] per hinge, by the kernels' own arithmetic (so rest is bitwise rest).

    Degenerate hinges give 0.
    """
    out = np.zeros(bending.shape[0])
    for c in range(bending.shape[0]):
        i1 = bending[c, 0]
        ox = positions[i1, 0]
        oy = positions[i1, 1]
        oz = positions[i1, 2]
        ax = positions[bending[c, 1], 0] - ox
        ay = positions[bending[c, 1], 1] - oy
        az = positions[bending[c, 1], 2] - oz
        bx = positions[bending[c, 2], 0] - ox
        by = positions[bending[c, 2], 1] - oy
        bz = positions[bending[c, 2], 2] - oz
        cx = positions[bending[c, 3], 0] - ox
        cy = positions[bending[c, 3], 1] - oy
        cz = positions[bending[c, 3], 2] - oz
        c1x = ay * bz - az * by
        c1y = az * bx - ax * bz
        c1z = ax * by - ay * bx
        c2x = ay * cz - az * cy
        c2y = az * cx - ax * cz
        c2z = ax * cy - ay * cx
        l1 = math.sqrt(c1x * c1x + c1y * c1y + c1z * c1z)
        l2 = math.sqrt(c2x * c2x + c2y * c2y + c2z * c2z)
        if l1 <= TINY_LENGTH or l2 <= TINY_LENGTH:
            continue
        # As _project_bend: atan2(|a| |det(a, b, c)|, (a×b)·(a×c)).
        length = math.sqrt(ax * ax + ay * ay + az * az)
        across = length * abs(c1x * cx + c1y * cy + c1z * cz)
        out[c] = math.atan2(across, c1x * c2x + c1y * c2y + c1z * c2z)
    return out


@njit(cache=True)
def edge_lengths(positions: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """``(e,) float64`` |p_i − p_j| [m] per edge, by the kernels' own arithmetic (so rest is bitwise rest)."""
    out = np.empty(edges.shape[0])
    for c in range(edges.shape[0]):
        i = edges[c, 0]
        j = edges[c, 1]
        d0 = positions[i, 0] - positions[j, 0]
        d1 = positions[i, 1] - positions[j, 1]
        d2 = positions[i, 2] - positions[j, 2]
        out[c] = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    return out


@njit(cache=True)
def signed_bend_angles(positions: np.ndarray, bending: np.ndarray) -> np.ndarray:
    """``(b,) float64`` signed angle β [rad] per hinge, by :func:`bend_gradient_signed`, the arithmetic of
    :func:`_project_bend_signed`.

    Degenerate hinges give 0.
    """
    out = np.zeros(bending.shape[0])
    for c in range(bending.shape[0]):
        valid, beta, _, _, _, _, _, _, _, _, _, _, _, _ = bend_gradient_signed(
            positions, bending[c, 0], bending[c, 1], bending[c, 2], bending[c, 3])
        if valid:
            out[c] = beta
    return out
