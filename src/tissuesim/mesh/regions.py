"""Node selectors for boundary conditions, shared by every method so all fix the same region."""

from __future__ import annotations

import numpy as np

from ..errors import BoundaryConditionError, first_indices

# The fixed region of the experiments (§8.2, Fig 6: "the bottom of M_V is subject to displacement constraints"):
# nodes within this fraction of the model's height above its lowest point.
BOTTOM_FRACTION = 0.1


def bottom_height(points: np.ndarray, *, fraction: float = BOTTOM_FRACTION, axis: int = 2) -> float:
    """The height [m] on ``axis`` below which nodes of ``points`` ``(n, 3)`` count as the bottom."""
    if not 0.0 < fraction < 1.0:
        raise BoundaryConditionError(f"bottom fraction must lie in (0, 1), got {fraction}")
    lo, hi = float(points[:, axis].min()), float(points[:, axis].max())
    return lo + fraction * (hi - lo)


def nodes_below(points: np.ndarray, height: float, *, axis: int = 2) -> np.ndarray:
    """``(k,) int32`` indices of ``points`` ``(n, 3)`` [m] with coordinate ``axis`` ≤ ``height`` [m]."""
    if axis not in (0, 1, 2):
        raise BoundaryConditionError(f"axis must be 0, 1 or 2 (x, y, z), got {axis}")
    selected = np.flatnonzero(points[:, axis] <= height + 1e-12 * max(1.0, abs(height))).astype(np.int32)
    if selected.size == 0:
        raise BoundaryConditionError(
            f"no node lies at or below {height:g} m on axis {'xyz'[axis]} (lowest is "
            f"{points[:, axis].min():g} m); raise the height"
        )
    return selected


def bottom_nodes(points: np.ndarray, *, fraction: float = BOTTOM_FRACTION, axis: int = 2) -> np.ndarray:
    """``(k,) int32`` the experiments' fixed region: nodes of ``points`` ``(n, 3)`` [m] at or below
    :func:`bottom_height` of those same points. To fix one region across meshes (M_S, M_V, fine volume), compute
    the height once from M_S and call :func:`nodes_below` on each mesh instead."""
    return nodes_below(points, bottom_height(points, fraction=fraction, axis=axis), axis=axis)


def nodes_above(points: np.ndarray, height: float, *, axis: int = 2) -> np.ndarray:
    """``(k,) int32`` indices of ``points`` ``(n, 3)`` [m] with coordinate ``axis`` ≥ ``height`` [m]."""
    if axis not in (0, 1, 2):
        raise BoundaryConditionError(f"axis must be 0, 1 or 2 (x, y, z), got {axis}")
    selected = np.flatnonzero(points[:, axis] >= height - 1e-12 * max(1.0, abs(height))).astype(np.int32)
    if selected.size == 0:
        raise BoundaryConditionError(
            f"no node lies at or above {height:g} m on axis {'xyz'[axis]} (highest is "
            f"{points[:, axis].max():g} m); lower the height"
        )
    return selected


def nodes_in_box(points: np.ndarray, lower, upper) -> np.ndarray:
    """``(k,) int32`` indices of ``points`` ``(n, 3)`` [m] inside the closed axis-aligned box ``lower`` ≤ x ≤
    ``upper`` (each ``(3,)`` [m]; use ±inf to leave an axis open)."""
    lower = np.asarray(lower, dtype=np.float64)
    upper = np.asarray(upper, dtype=np.float64)
    if lower.shape != (3,) or upper.shape != (3,) or np.any(np.isnan(lower)) or np.any(np.isnan(upper)):
        raise BoundaryConditionError(f"box corners must be (3,) numbers, got {lower.shape} and {upper.shape}")
    if np.any(lower > upper):
        raise BoundaryConditionError(f"box lower corner {lower.tolist()} exceeds upper corner {upper.tolist()}")
    slack = 1e-12 * np.maximum(1.0, np.abs(np.where(np.isfinite(upper), upper, 0.0)))
    inside = np.all((points >= lower - slack) & (points <= upper + slack), axis=1)
    selected = np.flatnonzero(inside).astype(np.int32)
    if selected.size == 0:
        raise BoundaryConditionError(
            f"no node lies in the box {lower.tolist()}..{upper.tolist()} m; the points span "
            f"{points.min(axis=0).tolist()}..{points.max(axis=0).tolist()} m"
        )
    return selected


def node_indices(indices, *, node_count: int) -> np.ndarray:
    """``(k,) int32`` sorted unique node indices from an explicit list, checked against ``0..node_count-1``."""
    indices = np.asarray(indices)
    if indices.ndim != 1 or indices.size == 0 or indices.dtype.kind not in "iu":
        raise BoundaryConditionError(
            f"node indices must be a non-empty 1-D integer array, got {indices.dtype} {indices.shape}"
        )
    bad = np.flatnonzero((indices < 0) | (indices >= node_count))
    if bad.size:
        raise BoundaryConditionError(
            f"{bad.size} node indices are outside 0..{node_count - 1} (first: {first_indices(indices[bad])}); "
            "check the mesh they refer to"
        )
    return np.unique(indices).astype(np.int32)
