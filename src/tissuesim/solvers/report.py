"""What a solver tells about its answer: the report of a quasi-static solve, and whether linear elasticity is
still a model of the body at a given displacement (for a static answer and for the state a step reached alike)."""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Linear elasticity (small strain, small rotation) is no longer a model of the body once a node moves more than
#: about this fraction of the model's size; :class:`SolveReport` and ``Solver.warning`` say so.
LINEAR_VALIDITY_FRACTION = 0.1


def linear_validity_warning(largest_displacement: float, model_size: float) -> str | None:
    """A sentence saying that linear elasticity is not valid for a state whose largest node displacement from rest
    is ``largest_displacement`` [m] on a model of size ``model_size`` [m]; None where it is."""
    if not largest_displacement > LINEAR_VALIDITY_FRACTION * model_size:
        return None
    return (f"linear elasticity is not valid here: a node moved {largest_displacement:.3g} m, "
            f"{largest_displacement / model_size:.2g} times the model's size {model_size:.3g} m "
            f"(small-strain theory holds to about {LINEAR_VALIDITY_FRACTION:g}); lower the load")


@dataclass(frozen=True)
class SolveReport:
    """What the last :meth:`Solver.solve_static` did.

    Attributes:
        steps: time steps taken.
        converged: whether the solve reached equilibrium (a static solve always; a stepped one when its
            extrapolated remaining error fell below ``rtol`` × the largest displacement, or its motion below
            ``tolerance``).
        max_motion: largest node motion [m] in the last step.
        tolerance: the absolute motion tolerance asked for [m] (0: none).
        elapsed: wall time of the solve [s].
        largest_displacement: largest node displacement from rest at the end [m].
        model_size: the model's size, the diagonal of M_S's rest bounding box [m].
    """

    steps: int
    converged: bool
    max_motion: float
    tolerance: float
    elapsed: float
    largest_displacement: float = math.nan
    model_size: float = math.nan

    @property
    def linear_valid(self) -> bool:
        """False when the largest displacement exceeds :data:`LINEAR_VALIDITY_FRACTION` of the model's size."""
        return linear_validity_warning(self.largest_displacement, self.model_size) is None

    @property
    def warning(self) -> str | None:
        """A sentence saying that linear elasticity is not valid for this answer, or None."""
        return linear_validity_warning(self.largest_displacement, self.model_size)
