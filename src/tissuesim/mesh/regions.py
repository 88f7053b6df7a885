"""Node selectors for boundary conditions, shared by every method so all fix the same region."""

from __future__ import annotations

import numpy as np

from ..errors import BoundaryConditionError

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
