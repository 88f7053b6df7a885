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
from numba import njit

from ..mesh.tetmesh import TetMesh
from .assembly import shape_gradients
from .hyperelastic import energy_density, piola_stress, project_psd, stress_tangent
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


@njit(cache=True)
def _deformation_gradient(x, elements, gradients, e, q, f):
    for i in range(3):
        for k in range(3):
            acc = 0.0
            for node in range(elements.shape[1]):
                acc += x[elements[e, node], i] * gradients[e, q, node, k]
            f[i, k] = acc


@njit(cache=True)
def quadratic_energy(x, elements, gradients, weights, params):
    """Σ_e Σ_q w_q Ψ(F_q) [J] at current positions ``x`` ``(N, 3)`` [m] of all nodes."""
    f = np.empty((3, 3))
    scratch = np.empty((5, 3, 3))
    total = 0.0
    for e in range(elements.shape[0]):
        for q in range(gradients.shape[1]):
            _deformation_gradient(x, elements, gradients, e, q, f)
            total += weights[e, q] * energy_density(f, params, scratch)
    return total


@njit(cache=True)
def quadratic_internal_forces(x, elements, gradients, weights, params, out):
    """``out`` ``(N, 3)`` = ∂W/∂x [N] (zero at rest)."""
    f = np.empty((3, 3))
    p = np.empty((3, 3))
    scratch = np.empty((5, 3, 3))
    out[:, :] = 0.0
    for e in range(elements.shape[0]):
        for q in range(gradients.shape[1]):
            _deformation_gradient(x, elements, gradients, e, q, f)
            piola_stress(f, params, p, scratch)
            w = weights[e, q]
            for node in range(elements.shape[1]):
                t = elements[e, node]
                for i in range(3):
                    acc = 0.0
                    for k in range(3):
                        acc += p[i, k] * gradients[e, q, node, k]
                    out[t, i] += w * acc


@njit(cache=True)
def quadratic_element_tangents(x, elements, gradients, weights, params, project, out):
    """``out`` ``(m, 30, 30)``: K_e[3a + i, 3b + j] = Σ_q w_q Σ_kl A_q[3i + k, 3j + l] ∇N_a,k ∇N_b,l [N/m], each A
    projected to positive semi-definite when ``project``."""
    width = elements.shape[1]
    f = np.empty((3, 3))
    a = np.empty((9, 9))
    scratch = np.empty((5, 3, 3))
    half = np.empty((width, 3, 9))   # Σ_k A[3i + k, ·] ∇N_a,k: the contraction on the left, once per point
    for e in range(elements.shape[0]):
        out[e, :, :] = 0.0
        for q in range(gradients.shape[1]):
            _deformation_gradient(x, elements, gradients, e, q, f)
            stress_tangent(f, params, a, scratch)
            if project:
                project_psd(a)
            g = gradients[e, q]
            w = weights[e, q]
            for na in range(width):
                for i in range(3):
                    for s in range(9):
                        half[na, i, s] = (a[3 * i, s] * g[na, 0] + a[3 * i + 1, s] * g[na, 1]
                                          + a[3 * i + 2, s] * g[na, 2])
            for na in range(width):
                for i in range(3):
                    for nb in range(width):
                        for j in range(3):
                            out[e, 3 * na + i, 3 * nb + j] += w * (half[na, i, 3 * j] * g[nb, 0]
                                                                  + half[na, i, 3 * j + 1] * g[nb, 1]
                                                                  + half[na, i, 3 * j + 2] * g[nb, 2])
