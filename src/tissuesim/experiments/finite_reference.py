"""The shipped finite-strain reference of the contact protocol's pull cases.

The default cube, its load node and 50 sample nodes (:mod:`.protocol`), pulled along +z over the contact patch of
R = 4 mm (the contact protocol's tip radius) at :data:`FORCES_N`; the stable neo-Hookean energy (Smith, de Goes &
Kim 2018) with E = 5500 Pa, ν = 0.3 on quadratic tets, refined like the linear contact reference (:mod:`.reference`).
The shipped levels stop short of its 2 % criterion: the last changed the samples by 4–5 % (``converged`` says so).
It was computed once, independently of the library's solvers (scikit-fem, by benchmarks/finite_strain_reference.py),
and is read from the package data here.
Each load also carries the linear answer on the same mesh under the same load, for comparison.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import SolverError

SCHEMA = "tissuesim-finite-reference/1"
DATA_FILE = Path(__file__).with_name("data") / "finite_strain_reference.json"
#: The pull magnitudes [N] and the patch radius [mm] of the reference.
FORCES_N = (0.1, 0.5, 1.0, 2.0, 5.0)
RADIUS_MM = 4.0

__all__ = ["DATA_FILE", "FORCES_N", "FiniteStrainReference", "RADIUS_MM", "SCHEMA", "load_finite_reference"]


@dataclass(frozen=True)
class FiniteStrainReference:
    """The reference of one model.

    Attributes:
        model: the built-in model's name. load_node: its load M_S vertex. radius_mm: patch radius R [mm].
        samples: ``(50,) int64`` the sample M_S vertices, the load node first.
        displacements: ``{force [N]: (50, 3) float64}`` the finite-strain displacement of the samples [m] under a
            pull of that force along +z.
        linear: ``{force [N]: (50, 3) float64}`` the linear answer [m] on the same mesh under the same load.
        changes: ``{force [N]: float}`` the relative change of the samples between the last two levels.
        levels: one dict per level computed (``level, tets, dofs, seconds, change``).
        converged: every load changed by less than ``tolerance`` at the last level.
    """

    model: str
    load_node: int
    radius_mm: float
    samples: np.ndarray
    displacements: dict
    linear: dict
    changes: dict
    levels: tuple
    tolerance: float
    converged: bool
    youngs_modulus: float
    poisson_ratio: float

    @property
    def forces(self) -> tuple:
        """The pull magnitudes [N], ascending."""
        return tuple(sorted(self.displacements))


def load_finite_reference(path: Path | str | None = None) -> FiniteStrainReference:
    """The shipped reference (or the one at ``path``); SolverError when it is missing or malformed."""
    path = Path(path) if path is not None else DATA_FILE
    try:
        document = json.loads(path.read_text())
    except FileNotFoundError:
        raise SolverError(f"the finite-strain reference {path} is missing; reinstall tissuesim, or recompute it "
                          "with benchmarks/finite_strain_reference.py") from None
    except (OSError, ValueError) as error:
        raise SolverError(f"the finite-strain reference {path} cannot be read ({error}); recompute it with "
                          "benchmarks/finite_strain_reference.py") from None
    if not isinstance(document, dict) or document.get("schema") != SCHEMA:
        found = document.get("schema") if isinstance(document, dict) else type(document).__name__
        raise SolverError(f"{path} is not a finite-strain reference (schema {found!r}, expected {SCHEMA!r}); "
                          "recompute it with benchmarks/finite_strain_reference.py")
    try:
        return _reference(document)
    except (KeyError, TypeError, ValueError) as error:
        raise SolverError(f"the finite-strain reference {path} is malformed ({error!r}); recompute it with "
                          "benchmarks/finite_strain_reference.py") from None


def _reference(document: dict) -> FiniteStrainReference:
    samples = np.asarray(document["samples"], dtype=np.int64)
    shape = (len(samples), 3)
    displacements, linear, changes = {}, {}, {}
    for entry in document["forces"].values():
        force = float(entry["force_N"])
        displacements[force] = np.asarray(entry["displacements"], dtype=np.float64)
        linear[force] = np.asarray(entry["linear"], dtype=np.float64)
        if displacements[force].shape != shape or linear[force].shape != shape:
            raise ValueError(f"the displacements at {force:g} N are not ({len(samples)}, 3)")
        changes[force] = None if entry["change"] is None else float(entry["change"])
    return FiniteStrainReference(
        model=str(document["model"]), load_node=int(document["load_node"]), radius_mm=float(document["radius_mm"]),
        samples=samples, displacements=displacements, linear=linear, changes=changes,
        levels=tuple(document["levels"]), tolerance=float(document["tolerance"]),
        converged=bool(document["converged"]), youngs_modulus=float(document["youngs_modulus"]),
        poisson_ratio=float(document["poisson_ratio"]))
