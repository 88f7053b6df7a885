"""What a solver tells about its answer: the report of a quasi-static solve, and whether its material is still a
model of the body there (for a static answer and for the state a step reached alike): linear elasticity up to a
displacement of a tenth of the body's size; a finite-strain material, through any rotation, up to elements crushed to
half their volume."""

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


#: A finite-strain material (corotated, neo-Hookean) is Hooke's law of E and ν carried to large rotations and
#: strains, not a law measured on tissue crushed this far: an element below this fraction of its volume (J = det F)
#: lies beyond what it models.
FINITE_RANGE_J = 0.5
#: An element crushed below this fraction of its volume is a collapse: a dead load too concentrated for its patch
#: (a tip pushed sideways crushes the surface ahead of it; a one-node pull tears a crater) has no stable equilibrium
#: that the mesh resolves, and the state Newton converges to is the mesh's, not the tissue's (the stable neo-Hookean
#: energy stays finite through J = 0, so it does converge there).
COLLAPSE_J = 0.1


def finite_range_warning(material: str, smallest_volume_ratio: float, crushed: int) -> str | None:
    """A sentence saying that the finite-strain ``material`` is beyond its range where ``crushed`` elements of the
    volume are below :data:`FINITE_RANGE_J` of their volume (the smallest J = ``smallest_volume_ratio``), and that
    the load has no stable equilibrium where one is below :data:`COLLAPSE_J`; else None. Large displacements and
    rotations are what such a material is for: they are never warned of."""
    if not crushed:
        return None
    smallest = f"smallest J = {smallest_volume_ratio:.2g}" + (" (≤ 0: inside out)" * (smallest_volume_ratio <= 0))
    fix = ("lower the load, spread it over a wider tip (radius=), or press with tissuesim.Probe, a rigid tip driven by "
           "displacement")
    if smallest_volume_ratio < COLLAPSE_J:
        return (f"the {material} body collapses under this load: elements of its volume are crushed below "
                f"{COLLAPSE_J:g} of their volume ({smallest}); a fixed force this concentrated has no stable "
                "equilibrium, and the answer near it is the mesh's, not the tissue's; " + fix)
    return (f"the {material} material is beyond its range here: {crushed} element(s) of the volume are crushed below "
            f"{FINITE_RANGE_J:g} of their volume ({smallest}), a strain its energy, fitted to E and ν at small strain, "
            "does not model; " + fix)


def validity_warning(material: str, largest_displacement: float, model_size: float,
                     smallest_volume_ratio: float = math.nan, crushed: int = 0) -> str | None:
    """The warning of a state under ``material``: :func:`linear_validity_warning` for the linear one, else
    :func:`finite_range_warning`."""
    if material == "linear":
        return linear_validity_warning(largest_displacement, model_size)
    return finite_range_warning(material, smallest_volume_ratio, crushed)


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
        material: the solver's material; with a finite-strain one, ``smallest_volume_ratio`` the smallest J = det F
            of its volume's elements and ``crushed`` how many lie below :data:`FINITE_RANGE_J` (NaN and 0 for linear).
    """

    steps: int
    converged: bool
    max_motion: float
    tolerance: float
    elapsed: float
    largest_displacement: float = math.nan
    model_size: float = math.nan
    material: str = "linear"
    smallest_volume_ratio: float = math.nan
    crushed: int = 0

    @property
    def linear_valid(self) -> bool:
        """False when the largest displacement exceeds :data:`LINEAR_VALIDITY_FRACTION` of the model's size."""
        return linear_validity_warning(self.largest_displacement, self.model_size) is None

    @property
    def warning(self) -> str | None:
        """A sentence saying that the material does not model this answer (linear elasticity: too large a
        displacement; finite strain: crushed elements), or None."""
        return validity_warning(self.material, self.largest_displacement, self.model_size,
                                self.smallest_volume_ratio, self.crushed)
