"""A solver's mutable state, and the measures of it that stepping and the quasi-static loop take each step
(compiled single passes over the ``(n, 3)`` arrays, so a step allocates nothing)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit


@dataclass
class State:
    """The mutable part of a solver.

    Attributes:
        positions: ``(n, 3) float64`` current M_S vertex positions [m].
        velocities: ``(n, 3) float64`` current M_S vertex velocities [m/s].
    """

    positions: np.ndarray
    velocities: np.ndarray

    @classmethod
    def at_rest(cls, rest_positions: np.ndarray) -> "State":
        """A state at ``rest_positions`` ``(n, 3)`` [m] with zero velocity (fresh, writable arrays)."""
        positions = np.array(rest_positions, dtype=np.float64, order="C", copy=True)
        return cls(positions, np.zeros_like(positions))


@njit(cache=True)
def motion_and_displacement(previous: np.ndarray, current: np.ndarray, rest: np.ndarray) -> tuple[float, float]:
    """``(largest |current − previous|, largest |current − rest|)`` components [m] over ``(n, 3)`` arrays; then
    copy current into previous."""
    motion = 0.0
    displacement = 0.0
    for i in range(previous.shape[0]):
        for k in range(3):
            c = current[i, k]
            motion = max(motion, abs(c - previous[i, k]))
            displacement = max(displacement, abs(c - rest[i, k]))
            previous[i, k] = c
    return motion, displacement


def remaining_error(motions: list[float], window: int = 5) -> float:
    """Distance [m] still to go, extrapolated from the last per-step motions ``motions`` as a geometric series
    (ratio ρ over ``window`` steps: error ≈ motion ρ/(1 − ρ)); inf while they do not shrink."""
    if len(motions) <= window or motions[-1] == 0.0:
        return 0.0 if motions and motions[-1] == 0.0 else np.inf
    ratio = (motions[-1] / motions[-1 - window]) ** (1.0 / window) if motions[-1 - window] > 0 else 1.0
    if not ratio < 1.0:
        return np.inf
    return motions[-1] * ratio / (1.0 - ratio)


@njit(cache=True)
def farthest_node(positions: np.ndarray, rest: np.ndarray) -> tuple[int, float]:
    """``(node, distance [m])`` of the node of ``positions`` ``(n, 3)`` farthest from ``rest`` ``(n, 3)``.

    A non-finite coordinate wins with distance inf (its node is returned), so one pass checks finiteness too.
    """
    worst, node = 0.0, -1
    for i in range(positions.shape[0]):
        d2 = 0.0
        for k in range(3):
            d = positions[i, k] - rest[i, k]
            d2 += d * d
        if not d2 <= worst:           # true for NaN and inf too
            if not np.isfinite(d2):
                return i, np.inf
            worst, node = d2, i
    return node, np.sqrt(worst)
