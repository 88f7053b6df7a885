"""Rest lengths of the new stretch constraints from the original ones (§7, eq 19–23, Fig 8).

A point inside (or on an edge of) a rest triangle ABC with barycentric coordinates λ = (λ1, λ2, λ3) has, to any
other such point, a distance fixed by the triangle's three rest lengths alone: the new constraints need neither the
rest positions nor the current shape.

* eq 19, edge point P on AB (λ3 = 0). The paper prints l_AP = λ1/(λ1 + λ2) l_AB, which with λ1 the weight of A is
  the length of PB; the distance from A grows with B's weight: l_AP = λ2/(λ1 + λ2) l_AB (:func:`edge_point_length`).
* eq 20–23, facet point P: cos α at C from the law of cosines (eq 20), D = the point where AP meets BC with
  l_DC = λ2/(λ2 + λ3) l_BC (eq 21), l_AD by the law of cosines (eq 22), l_AP = (λ2 + λ3) l_AD (eq 23)
  (:func:`facet_point_length`).
* Any two points P, Q of one triangle (what a cut also needs: edge point to edge point, facet to facet):
  with d = λ_P − λ_Q (Σ d = 0), |PQ|² = −(d1 d2 l_AB² + d2 d3 l_BC² + d3 d1 l_CA²)
  (:func:`barycentric_distance`), which reduces to eq 19 and eq 20–23 in their cases (tested).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def edge_point_length(l_ab: ArrayLike, lam1: ArrayLike, lam2: ArrayLike) -> float | np.ndarray:
    """Eq 19: rest length [m] from A to the edge point P = λ1 A + λ2 B of AB (see the module docstring)."""
    return np.asarray(lam2) / (np.asarray(lam1) + np.asarray(lam2)) * np.asarray(l_ab)


def facet_point_length(l_ab: float | np.ndarray, l_bc: float | np.ndarray, l_ac: float | np.ndarray,
                       lam: ArrayLike) -> float | np.ndarray:
    """Eq 20–23: rest length [m] from A to the facet point with barycentric ``lam`` ``(..., 3)`` in ABC."""
    lam = np.asarray(lam, dtype=np.float64)
    lam2, lam3 = lam[..., 1], lam[..., 2]
    cos_alpha = (l_bc ** 2 + l_ac ** 2 - l_ab ** 2) / (2.0 * l_bc * l_ac)          # eq 20
    l_dc = lam2 / (lam2 + lam3) * l_bc                                              # eq 21
    l_ad = np.sqrt(np.maximum(l_dc ** 2 + l_ac ** 2 - 2.0 * l_dc * l_ac * cos_alpha, 0.0))  # eq 22
    return (lam2 + lam3) * l_ad                                                     # eq 23


def barycentric_distance(lengths: ArrayLike, first: ArrayLike, second: ArrayLike) -> float | np.ndarray:
    """Rest distance [m] between points with barycentric ``first``, ``second`` ``(..., 3)`` in triangles whose
    rest side lengths are ``lengths`` ``(..., 3)`` = (l_AB, l_BC, l_CA) [m] (the general form of eq 19–23)."""
    d = np.asarray(first, dtype=np.float64) - np.asarray(second, dtype=np.float64)
    l2 = np.asarray(lengths, dtype=np.float64) ** 2
    square = -(d[..., 0] * d[..., 1] * l2[..., 0] + d[..., 1] * d[..., 2] * l2[..., 1]
               + d[..., 2] * d[..., 0] * l2[..., 2])
    return np.sqrt(np.maximum(square, 0.0))
