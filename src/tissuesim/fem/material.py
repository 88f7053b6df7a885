"""Isotropic linear-elastic material: Young's modulus and Poisson's ratio → the elastic matrix D of eq (4)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import MaterialError, warn
from ..loads import number_fix, real_number

# The paper's tissue (§8.3): E = 5.5 kPa, ν = 0.3.
DEFAULT_YOUNGS_MODULUS = 5500.0
DEFAULT_POISSON_RATIO = 0.3
# Linear tetrahedra lock as ν → 0.5 (their constant strain cannot be volume-preserving everywhere): they grow too
# stiff. Measured, fine FEM of the cube, 1 N on the top node, displacement relative to ν = 0.3: 0.69 at ν = 0.45,
# 0.34 at 0.49, 0.023 at 0.4999, 0.003 at 0.49999, where elasticity (Boussinesq, ∝ 1 − ν²) gives 0.88, 0.84, 0.82.
#: Above this ν the model is too stiff by more than 1.25x: a TissuesimWarning.
LOCKING_WARNING_POISSON_RATIO = 0.45
#: Above this ν the model is too stiff by 2.5x or more: refused.
MAX_POISSON_RATIO = 0.49


@dataclass(frozen=True)
class Material:
    """Isotropic, homogeneous, linear-elastic material (small strain).

    Attributes:
        youngs_modulus: E [Pa], finite and > 0.
        poisson_ratio: ν [-], finite, in (-1, :data:`MAX_POISSON_RATIO`]. Linear tets lock as ν → 0.5 (ν = 0.5
            makes λ infinite), so ν above 0.49 is refused and ν above 0.45 warns (see the figures above).
    """

    youngs_modulus: float = DEFAULT_YOUNGS_MODULUS
    poisson_ratio: float = DEFAULT_POISSON_RATIO

    def __post_init__(self):
        for name in ("youngs_modulus", "poisson_ratio"):
            value = getattr(self, name)
            number = real_number(value)     # no text (a string would silently parse) and no bool (True is 1.0)
            if number is None:
                what = "the bool " if isinstance(value, (bool, np.bool_)) else ""
                raise MaterialError(f"{name} must be a real number, got {what}{value!r}; "
                                    f"{number_fix(value, '5500' if name == 'youngs_modulus' else '0.3')}")
            value = number
            if not math.isfinite(value):
                raise MaterialError(f"{name} must be finite, got {value}")
            object.__setattr__(self, name, value)
        # values are printed with repr: %g would round 0.4999999 to 0.5 and 0.4900001 to 0.49
        if self.youngs_modulus <= 0.0:
            raise MaterialError(
                f"youngs_modulus must be > 0 Pa, got {self.youngs_modulus!r}; soft tissue is ~1e3-1e5 Pa "
                "(the paper uses 5500)"
            )
        if self.poisson_ratio <= -1.0:
            raise MaterialError(
                f"poisson_ratio must lie in (-1, {MAX_POISSON_RATIO}], got {self.poisson_ratio!r} (-1 makes the bulk "
                "modulus zero, and below it the material is unstable); soft tissue is about 0.3 to 0.49"
            )
        if self.poisson_ratio >= 0.5:
            raise MaterialError(
                f"poisson_ratio must lie in (-1, {MAX_POISSON_RATIO}], got {self.poisson_ratio!r} (0.5 makes the "
                "Lame parameter lambda infinite)"
            )
        if self.poisson_ratio > MAX_POISSON_RATIO:
            raise MaterialError(
                f"poisson_ratio {self.poisson_ratio!r} is above {MAX_POISSON_RATIO}: linear tetrahedra lock near "
                "incompressibility and come out far too stiff (at 0.49999 the cube moves 0.1 mm where 0.3 gives "
                f"31.9 mm); use at most {MAX_POISSON_RATIO}"
            )
        if self.poisson_ratio > LOCKING_WARNING_POISSON_RATIO:
            warn(
                f"poisson_ratio {self.poisson_ratio!r} > {LOCKING_WARNING_POISSON_RATIO}: linear tetrahedra lock "
                "near incompressibility, so displacements come out too small (measured on the cube at 0.49: 0.4 "
                "of linear elasticity's)")

    @property
    def lame_lambda(self) -> float:
        """First Lamé parameter λ = Eν / ((1+ν)(1−2ν)) [Pa]."""
        e, nu = self.youngs_modulus, self.poisson_ratio
        return e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))

    @property
    def shear_modulus(self) -> float:
        """Shear modulus μ = G = E / (2(1+ν)) [Pa] (second Lamé parameter)."""
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def bulk_modulus(self) -> float:
        """Bulk modulus K = E / (3(1−2ν)) [Pa]."""
        return self.youngs_modulus / (3.0 * (1.0 - 2.0 * self.poisson_ratio))

    def elasticity_matrix(self) -> np.ndarray:
        """``(6, 6) float64`` D [Pa] of eq (4), σ = D ε, Voigt order (xx, yy, zz, xy, yz, zx) with engineering
        shear strains (γ_xy = 2 ε_xy), matching the strain matrix B of :mod:`tissuesim.fem.assembly`."""
        lam, mu = self.lame_lambda, self.shear_modulus
        d = np.zeros((6, 6))
        d[:3, :3] = lam
        d[[0, 1, 2], [0, 1, 2]] = lam + 2.0 * mu
        d[[3, 4, 5], [3, 4, 5]] = mu
        return d
