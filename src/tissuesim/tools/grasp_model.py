"""What a grasper (:mod:`tissuesim.tools.grasper`) computes that knows no grasper: the jaws' rotation checked, the
model of the held vertices' compliance sized by a first solve, the largest miss, and the solver's hooks a grasper
uses (its compliance, whether it follows by relaxed updates)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SolverError
from ..solvers.checks import numeric_array
from ..solvers.finite_strain import slow_static_solve

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..solvers.base import Solver

#: How far a rotation matrix may be from orthonormal (max |RᵀR − I|) and still be taken as one.
ROTATION_TOLERANCE = 1e-6


def follows_by_updates(solver: Solver) -> bool:
    """Whether :meth:`~tissuesim.tools.grasper.Grasper.follow` updates rather than settles on ``solver``: its static
    solve is slow (:func:`~.solvers.finite_strain.slow_static_solve`) and it has its own compliance to update by."""
    return slow_static_solve(solver) and getattr(solver, "point_compliance", None) is not None


def solver_compliance(solver: Solver, hook: str, held: np.ndarray) -> np.ndarray | None:
    """The solver's answer to an optional compliance ``hook`` for the ``held`` vertices, or None."""
    found = getattr(solver, hook, None)
    return None if found is None else found(held)


def checked_rotation(rotation: ArrayLike) -> np.ndarray:
    """``(3, 3) float64`` ``rotation`` checked to be a proper rotation matrix (RᵀR = I, det R = +1)."""
    matrix = numeric_array(rotation)
    if matrix is None or matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
        what = ("no array of numbers" if matrix is None
                else f"shape {matrix.shape}, all finite: {bool(np.isfinite(matrix).all())}")
        raise SolverError(f"the jaws' rotation must be a (3, 3) matrix of finite numbers, got {what}; pass e.g. "
                          "scipy.spatial.transform.Rotation.from_rotvec(v).as_matrix()")
    off = float(np.abs(matrix.T @ matrix - np.eye(3)).max())
    if off > ROTATION_TOLERANCE or np.linalg.det(matrix) < 0.0:
        raise SolverError(
            f"the jaws' rotation is not a proper rotation (|RᵀR − I| = {off:.3g}, det R = "
            f"{np.linalg.det(matrix):.3g}); pass an orthonormal matrix with determinant +1, e.g. from "
            "scipy.spatial.transform.Rotation.as_matrix()")
    return matrix.copy()


def fitted_model(model: np.ndarray, change: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """α J + β I with α ≥ 0, β ≥ 0 fitted (least squares) to the held vertices' motion ``moved`` ``(3k,)`` [m] in
    the first solve under the forces' ``change`` ``(3k,)`` [N]: a model's size is E's and the mesh's, and what a
    coarse model leaves out is mostly each vertex's own dimple (the hybrid's layer between control nodes), which
    β I stands for; Broyden then learns the rest."""
    predicted = model @ change
    basis = np.column_stack([predicted, change])
    (alpha, beta), *_ = np.linalg.lstsq(basis, moved, rcond=None)
    if beta < 0.0 or alpha < 0.0:       # one term alone: the one that explains the motion
        alpha = max(float(moved @ predicted) / float(predicted @ predicted), 1e-3)
        beta = 0.0
    return alpha * model + beta * np.eye(len(model))


def largest_miss(error: np.ndarray) -> float:
    """The largest length [m] among the rows of ``error`` ``(k, 3)`` (0 for none)."""
    return float(np.linalg.norm(error, axis=1).max()) if error.size else 0.0
