"""Deformation methods over a hybrid mesh, chosen by name: hybrid (the paper's §6), pbd, mass-spring, embedded, fem.

    solver = make_solver("hybrid", hybrid_mesh)             # paper material, bottom fixed, calibrated layer
    positions = solver.solve_static(node, [0.0, 0.0, -1.0])  # (n, 3) M_S positions at equilibrium [m]

Each method lives in its own module and is imported on first use (see :mod:`tissuesim.solvers.registry`).
"""

from .attachments import Attachment
from .base import Solver
from .registry import (available_solvers, make_solver, method_names, register, solver_class, solver_options,
                       unregister)
from .report import SolveReport
from .state import State

__all__ = [
    "Attachment", "SolveReport", "Solver", "State", "available_solvers", "make_solver", "method_names", "register",
    "solver_class", "solver_options", "unregister",
]
