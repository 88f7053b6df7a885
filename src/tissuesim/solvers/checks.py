"""Checks of the solvers' arguments: each returns the value in its canonical type or raises an error naming it."""

from __future__ import annotations

import numpy as np

from ..errors import BoundaryConditionError, SolverError, first_indices

def positive_number(name: str, value, unit: str) -> float:
    """``value`` as a float, or a :class:`SolverError` naming ``name`` and its ``unit`` unless positive and finite."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise SolverError(f"{name} must be a number [{unit}], got {value!r}") from None
    if not np.isfinite(value) or value <= 0.0:
        raise SolverError(f"{name} must be a positive finite number [{unit}], got {value!r}")
    return value


def is_integer(value) -> bool:
    """True for an int or NumPy integer (not a bool: True would otherwise mean node 1), or an integral float."""
    if isinstance(value, (bool, np.bool_)):
        return False
    if isinstance(value, (int, np.integer)):
        return True
    return isinstance(value, (float, np.floating)) and float(value).is_integer()


def fraction(name: str, value) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise SolverError(f"{name} must be a number in [0, 1), got {value!r}") from None
    if not (0.0 <= value < 1.0):
        raise SolverError(f"{name} must lie in [0, 1) (fraction of velocity removed per step), got {value!r}")
    return value


def check_force(force) -> np.ndarray:
    try:
        force = np.asarray(force, dtype=np.float64)
    except (TypeError, ValueError):
        raise SolverError(f"force must be 3 numbers [N], got {force!r}") from None
    if force.shape != (3,):
        raise SolverError(f"force must have shape (3,) [N], got shape {force.shape}")
    if not np.all(np.isfinite(force)):
        raise SolverError(f"force must be finite [N], got {force.tolist()}")
    return force


def node_set(name: str, nodes, count: int) -> np.ndarray:
    nodes = np.asarray(nodes)
    if nodes.dtype == bool:
        if nodes.shape != (count,):
            raise BoundaryConditionError(f"boolean {name} mask must have shape ({count},), got {nodes.shape}")
        nodes = np.flatnonzero(nodes)
    if nodes.size and not np.issubdtype(nodes.dtype, np.integer):
        raise BoundaryConditionError(f"{name} must be integer M_S vertex indices, got dtype {nodes.dtype}")
    nodes = nodes.astype(np.int64).ravel()
    if nodes.size == 0:
        raise BoundaryConditionError(
            f"{name} is empty: the body would move freely; pass M_S vertex indices or leave it at its default "
            "(the model's bottom)"
        )
    bad = np.flatnonzero((nodes < 0) | (nodes >= count))
    if bad.size:
        raise BoundaryConditionError(
            f"{bad.size} {name} indices lie outside 0..{count - 1} (first positions in the list: "
            f"{first_indices(bad)})"
        )
    return np.unique(nodes).astype(np.int32)
