"""Camera rays of the simulator's pointer: where a drag goes in the plane facing the camera."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SolverError
from ..solvers.checks import checked_point

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def camera_plane_point(origin: ArrayLike, direction: ArrayLike, anchor: ArrayLike) -> np.ndarray | None:
    """``(3,)`` point [m] where the ray ``origin + t direction`` meets the plane through ``anchor`` facing it.

    The plane's normal is the ray direction, so moving the cursor moves the point parallel to the screen. Returns
    None when the anchor lies behind the camera; SolverError for a ray that is not 3 finite numbers, not all zero.
    """
    origin, anchor = checked_point(origin), checked_point(anchor)
    direction = unit_ray(direction)
    t = float(np.dot(anchor - origin, direction))
    return None if t <= 0.0 else origin + t * direction


def unit_ray(direction: ArrayLike) -> np.ndarray:
    """``direction`` ``(3,)`` of a camera ray as a unit vector, or SolverError (a window that hands over a zero or
    NaN ray would otherwise put NaN into a drag or a blade)."""
    try:
        vector = np.asarray(direction, dtype=np.float64)
    except (TypeError, ValueError):
        vector = np.full(3, np.nan)
    with np.errstate(over="ignore"):  # a ray of 1e200 is a direction all the same: scaled by its largest part
        largest = float(np.max(np.abs(vector))) if vector.shape == (3,) else np.nan
        if np.isfinite(largest) and largest > 0.0:
            vector = vector / largest
            return vector / np.linalg.norm(vector)
    raise SolverError(f"the camera ray's direction must be 3 finite numbers, not all zero, got {direction!r}; "
                      "the pointer event is ignored")
