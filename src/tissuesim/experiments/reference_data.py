"""The data of a contact reference (:mod:`.reference`): how it is refined, its convergence table, its response."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import SolverError
from . import protocol

#: Elements of the reference volume (:attr:`RefinementSettings.element`).
ELEMENTS = ("quadratic", "linear")

@dataclass(frozen=True)
class RefinementSettings:
    """How the reference is refined (keyword-only; the defaults are what the contact protocol uses).

    Attributes:
        grading: growth of the target edge length with the distance beyond the patch [m per m] at level 0.
        grading_ratio: factor on that growth per level (2^-1/2), so every size shrinks from one level to the next:
            h_c halves at the contact and the field beyond it refines too (the far displacements depend on the
            whole body's stiffness, which local refinement alone leaves unconverged).
        interior_ratio: if set, factor per level on an interior edge length bound ``h0 · interior_ratio^ℓ``
            (TetGen's ``a`` switch, a bound on every tet's volume), so the deep interior refines too. None (default):
            the interior is graded from the refined surface by TetGen's quality switch alone. Measured on the cube
            (R = 4 / 8 mm, level 4): with 2^-1/4 the sample RMS is 4.3 / 3.7 % higher at 4.7× the tets and 8× the
            time, and R = 4 mm still changes 1.25 % at level 4; the default converges by the 1 % criterion at level
            4 in 20 s. That gap is a bias of the default reference the criterion does not see (docs/experiments.md).
        tolerance: relative change of the sample displacements between two levels at which a level counts as
            converged (0.01 = 1 %).
        max_levels: the last level tried (level 0 is the default fine volume).
        min_levels: the first level at which convergence may be declared (≥ 1: a change needs two levels).
            Fewer than that many levels (max_levels < min_levels) is never converged.
        samples: how many M_S nodes nearest the contact are compared (:func:`protocol.sample_nodes`).
        max_surface_vertices: a level whose refined surface would exceed this many vertices is not computed (the
            refinement stops there, unconverged): it bounds the cost on a model that is small against R (about
            150k tets and a minute on 2 cores at the bound).
        element: ``"quadratic"`` (default: 10-node tets, :mod:`tissuesim.fem.quadratic`, loaded by a uniform
            traction on the refined surface's triangles whose centroid lies within R) or ``"linear"`` (the
            solvers' 4-node tets, loaded by the contact patch rule on the refined surface's nodes). On the cube
            (R = 4 mm) the linear levels still change by 1–2 % at levels 4 and 5 (365k tets); the quadratic ones
            change by 0.68 % at level 3 (25k tets).
    """

    grading: float = 0.5
    grading_ratio: float = 2.0 ** -0.5
    interior_ratio: float | None = None
    tolerance: float = 0.01
    max_levels: int = 4
    min_levels: int = 1
    samples: int = protocol.RMSE_SAMPLES
    max_surface_vertices: int = 16000
    element: str = "quadratic"

    def __post_init__(self):
        ratios = (self.grading_ratio, 1.0 if self.interior_ratio is None else self.interior_ratio)
        if not (self.grading > 0 and all(0 < r <= 1 for r in ratios) and self.tolerance > 0):
            raise SolverError(f"refinement settings need grading > 0, ratios in (0, 1] and tolerance > 0, got "
                              f"{self.grading}, {ratios}, {self.tolerance}")
        counts = (self.max_levels, self.min_levels, self.samples, self.max_surface_vertices)
        if not all(isinstance(c, (int, np.integer)) and not isinstance(c, bool) for c in counts):
            raise SolverError(f"refinement levels, samples and the surface bound must be whole numbers, got {counts}")
        if not np.isfinite(self.grading) or self.max_surface_vertices < 1:
            raise SolverError(f"refinement settings need a finite grading and a positive surface bound, got "
                              f"{self.grading} and {self.max_surface_vertices}")
        if self.min_levels < 1 or self.max_levels < 0:
            raise SolverError(f"need min_levels ≥ 1 and max_levels ≥ 0, got {self.min_levels} and {self.max_levels}")
        if self.element not in ELEMENTS:
            raise SolverError(f"unknown element {self.element!r}; choose one of {', '.join(ELEMENTS)}")


@dataclass(frozen=True)
class LevelRow:
    """One row of a convergence table.

    Attributes:
        level: refinement level (0: the default fine volume).
        tets, nodes: size of the level's volume mesh.
        contact_size_mm: target surface edge length at the contact [mm] (h_c).
        grading: slope of the size field beyond the patch [m/m] (None at level 0: TetGen's quality switches).
        sample_rms_mm: RMS displacement of the sample nodes under 1 N along −z [mm].
        contact_mm: displacement of the contact node under 1 N along −z [mm].
        others_rms_mm: RMS displacement of the samples other than the contact node under 1 N along −z [mm].
        change: relative change of the sample displacements from the previous level (None at level 0), the largest
            over the three load axes.
    """

    level: int
    tets: int
    nodes: int
    contact_size_mm: float
    grading: float | None
    sample_rms_mm: float
    contact_mm: float
    others_rms_mm: float
    change: float | None


@dataclass(frozen=True)
class ContactReference:
    """The converged (or last) reference response of one contact.

    Attributes:
        node: the contact M_S node.
        radius: patch radius [m] (None: single-node load).
        response: ``(n, 3, 3) float64`` [m/N]: ``response[i, a, b]`` is M_S node i's displacement along a under a
            unit force along b spread over the patch.
        samples: ``(k,) int64`` the compared M_S nodes (nearest the contact first).
        levels: the convergence table, one :class:`LevelRow` per level computed.
        converged: whether the last change fell below the tolerance.
        youngs_modulus, poisson_ratio: the material [Pa], [-].
        nodal_response: ``(n, 3, 3) float64`` [m/N] or None: the same for the solvers' nodal forces (module
            docstring; quadratic elements only).
    """

    node: int
    radius: float | None
    response: np.ndarray
    samples: np.ndarray
    levels: tuple
    converged: bool
    youngs_modulus: float
    poisson_ratio: float
    settings: RefinementSettings = field(default_factory=RefinementSettings)
    nodal_response: np.ndarray | None = None

    def displacements(self, force: np.ndarray | Sequence[float]) -> np.ndarray:
        """``(n, 3) float64`` M_S displacements [m] under ``force`` ``(3,)`` [N] spread over the patch."""
        return self.response @ np.asarray(force, dtype=np.float64)

    @property
    def load_rule_floor(self) -> float | None:
        """Relative RMSE over the samples of the response to the solvers' nodal forces against :attr:`response`,
        for a force along −z (the same for any force along z: both are linear); None without
        :attr:`nodal_response`."""
        if self.nodal_response is None:
            return None
        exact, nodal = -self.response[self.samples, :, 2], -self.nodal_response[self.samples, :, 2]
        return float(np.sqrt(np.mean(np.sum((nodal - exact) ** 2, axis=1)) / np.mean(np.sum(exact ** 2, axis=1))))


def format_row(row: LevelRow) -> str:
    """One line of a convergence table for progress output."""
    change = "–" if row.change is None else f"{100 * row.change:.2f} %"
    return (f"level {row.level}: {row.tets} tets, h_c {row.contact_size_mm:.3g} mm, sample RMS "
            f"{row.sample_rms_mm:.4g} mm/N, change {change}")
