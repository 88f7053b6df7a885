"""Finite strain on quadratic (10-node) tets: the per-point material kernels of :mod:`.hyperelastic` (Ψ, P, A)
integrated over each element, total Lagrangian.

* **Deformation gradient.** F = Σ_a x_a ⊗ ∇N_a at each quadrature point, with the 10 quadratic shape-function
  gradients of :mod:`.quadratic` in the rest configuration (corners, then midsides in ``TET_EDGES`` order). F varies
  linearly over an element, so a quadratic element represents a homogeneous deformation exactly, and a bent one too.
* **Quadrature.** The 4-point rule of degree 2 that :class:`~.quadratic.QuadraticFEM` uses for K, weight V/4 per
  point. At rest A is Hooke's constant tensor and ∇N linear, so the tangent at rest is exactly QuadraticFEM's K₀
  (the first Newton step from rest is the small-strain answer); away from rest the rule is an approximation of the
  same order as the element.
* **Element quantities** (node-major local dofs, 30 per element): forces f_a = Σ_q w_q P_q ∇N_a(q), stiffness
  K_ab = Σ_q w_q ∇N_a(q)ᵀ A_q ∇N_b(q) in the index convention of :mod:`.hyperelastic`.
"""

from __future__ import annotations

import numpy as np

from ..mesh.tetmesh import TetMesh
from .assembly import shape_gradients
from .quadratic import QUADRATURE, TET_EDGES


def quadrature_gradients(mesh: TetMesh) -> tuple[np.ndarray, np.ndarray]:
    """``(gradients (m, q, 10, 3) float64 [1/m], weights (m, q) float64 [m³])``: the rest gradients of the 10 quadratic
    shape functions of each tet at the q = 4 points of :data:`~.quadratic.QUADRATURE`, and each point's volume
    weight V/4 (module docstring; ∇N_a = (4 L_a − 1) ∇L_a, ∇N_ab = 4 (L_b ∇L_a + L_a ∇L_b))."""
    linear = shape_gradients(mesh)                            # (m, 4, 3): ∇L_a
    points = QUADRATURE                                       # (q, 4): barycentric L at each point
    gradients = np.empty((len(linear), len(points), 10, 3))
    gradients[:, :, :4] = (4.0 * points - 1.0)[None, :, :, None] * linear[:, None]
    a, b = TET_EDGES[:, 0], TET_EDGES[:, 1]
    gradients[:, :, 4:] = 4.0 * (points[None, :, b, None] * linear[:, None, a]
                                 + points[None, :, a, None] * linear[:, None, b])
    weights = np.repeat(0.25 * np.asarray(mesh.volumes, dtype=np.float64)[:, None], len(points), axis=1)
    return gradients, weights
