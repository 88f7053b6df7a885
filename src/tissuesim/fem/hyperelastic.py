"""Finite-strain materials on linear tetrahedra: energy density Ψ(F), first Piola stress P = ∂Ψ/∂F and the tangent
A = ∂P/∂F, per element and summed to nodal forces and a global tangent stiffness.

Two materials beyond the paper's small-strain elasticity, both parametrised by the same E and ν and both reducing to
it (Hooke's law) for small strains:

* ``"corotated"``: fixed corotated elasticity (Stomakhin et al. 2012), Ψ = μ |F − R|² + λ/2 (J − 1)², R the rotation
  of F's polar decomposition taken from an inversion-aware SVD (det U = det V = 1, the last singular value carries
  the sign of J). The linear corotational FEM of SOFA and Vega in energy form: rotations cost nothing, and the
  tangent below is consistent (dR/dF from the SVD), so Newton converges quadratically.
* ``"neo-hookean"``: the stable neo-Hookean energy of Smith, de Goes & Kim 2018 ("Stable Neo-Hookean Flesh
  Simulation", ACM TOG 37(2), eq 14), Ψ = μ'/2 (I_C − 3) + λ'/2 (J − α)² − μ'/2 log(I_C + 1) with μ' = 4/3 μ,
  λ' = λ + 5/6 μ and α = 1 + 3 μ'/(4 λ'), so that it is stress-free at rest and linearises to Hooke's law with the
  Lamé constants λ, μ of E and ν (the paper's §3.4). It has no log J: finite and smooth through inversion (J ≤ 0),
  where the classic compressible neo-Hookean is undefined.

Conventions: F = Σ_a x_a ⊗ ∇N_a (current positions x, rest shape-function gradients ∇N_a of
:func:`~tissuesim.fem.assembly.shape_gradients`); a 3×3 matrix M is the 9-vector M[3 i + k]; A[3 i + k, 3 j + l] =
∂P_ik/∂F_jl. Element forces are −V P ∇N_a, element stiffnesses K_ab = V ∇N_aᵀ A ∇N_b (node-major dofs, as
:mod:`~tissuesim.fem.assembly`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..errors import MaterialError

MATERIALS = ("linear", "corotated", "neo-hookean")
DEFAULT_MATERIAL = "linear"
_CODES = {"corotated": 1, "neo-hookean": 2}
#: Floor of σ_i + σ_j in dR/dF: an element flattened to a line (two singular values zero) has no defined rotation
#: rate; the floor keeps its tangent finite, and the projection keeps it positive.
SINGULAR_FLOOR = 1e-8


def check_material(material: object) -> str:
    """``material`` if it is one of :data:`MATERIALS`, else MaterialError naming the choices."""
    if not isinstance(material, str) or material not in MATERIALS:
        raise MaterialError(f"unknown material {material!r}; choose one of {', '.join(map(repr, MATERIALS))} "
                            "('linear' is the paper's small-strain elasticity)")
    return material


def material_parameters(material: str, *, shear_modulus: float, lame_lambda: float) -> np.ndarray:
    """``(4,) float64`` kernel parameters (code, μ', λ', α) of a finite-strain ``material`` from the Lamé constants
    [Pa] (see the module docstring for μ', λ', α; the corotated material uses μ, λ and α = 1 as they are)."""
    code = _CODES.get(check_material(material))
    if code is None:
        raise MaterialError("the 'linear' material has no finite-strain kernel; use tissuesim.fem.linear.LinearFEM")
    if code == 1:
        return np.array([1.0, shear_modulus, lame_lambda, 1.0])
    mu, lam = 4.0 / 3.0 * shear_modulus, lame_lambda + 5.0 / 6.0 * shear_modulus
    return np.array([2.0, mu, lam, 1.0 + 0.75 * mu / lam])


# ------------------------------------------------------------------------------------------ one element's maths

@njit(cache=True, inline="always")
def _det3(a):
    """det of a 3×3 matrix in closed form (LAPACK's, on a copy, costs ~10x more per element)."""
    return (a[0, 0] * (a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]) - a[0, 1] * (a[1, 0] * a[2, 2] - a[1, 2] * a[2, 0])
            + a[0, 2] * (a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]))


@njit(cache=True)
def _cofactor(f, out):
    """out = cof F = J F⁻ᵀ (the derivative of J = det F), defined for every F."""
    out[0, 0] = f[1, 1] * f[2, 2] - f[1, 2] * f[2, 1]
    out[0, 1] = f[1, 2] * f[2, 0] - f[1, 0] * f[2, 2]
    out[0, 2] = f[1, 0] * f[2, 1] - f[1, 1] * f[2, 0]
    out[1, 0] = f[0, 2] * f[2, 1] - f[0, 1] * f[2, 2]
    out[1, 1] = f[0, 0] * f[2, 2] - f[0, 2] * f[2, 0]
    out[1, 2] = f[0, 1] * f[2, 0] - f[0, 0] * f[2, 1]
    out[2, 0] = f[0, 1] * f[1, 2] - f[0, 2] * f[1, 1]
    out[2, 1] = f[0, 2] * f[1, 0] - f[0, 0] * f[1, 2]
    out[2, 2] = f[0, 0] * f[1, 1] - f[0, 1] * f[1, 0]


@njit(cache=True)
def _add_determinant_hessian(f, scale, a):
    """a += scale ∂²J/∂F∂F, whose entries are Σ_mn ε_ijm ε_kln F_mn (linear in F)."""
    for i in range(3):
        for j in range(3):
            if i == j:
                continue
            m = 3 - i - j
            s_ij = 1.0 if (j - i) % 3 == 1 else -1.0  # ε_ijm for distinct i, j, m
            for k in range(3):
                for l in range(3):
                    if k == l:
                        continue
                    n = 3 - k - l
                    s_kl = 1.0 if (l - k) % 3 == 1 else -1.0
                    a[3 * i + k, 3 * j + l] += scale * s_ij * s_kl * f[m, n]


@njit(cache=True)
def _rotation(f, u, sigma, vt, r):
    """Inversion-aware SVD F = U diag(σ) Vᵀ with det U = det V = 1 (σ_3 < 0 when J < 0), and R = U Vᵀ, in place."""
    uu, ss, vv = np.linalg.svd(f)
    for c in range(3):
        sigma[c] = ss[c]
        for k in range(3):
            u[k, c] = uu[k, c]
            vt[c, k] = vv[c, k]
    if _det3(u) < 0.0:
        for k in range(3):
            u[k, 2] = -u[k, 2]
        sigma[2] = -sigma[2]
    if _det3(vt) < 0.0:
        for k in range(3):
            vt[2, k] = -vt[2, k]
        sigma[2] = -sigma[2]
    for i in range(3):
        for k in range(3):
            r[i, k] = u[i, 0] * vt[0, k] + u[i, 1] * vt[1, k] + u[i, 2] * vt[2, k]


@njit(cache=True)
def energy_density(f: np.ndarray, params: np.ndarray, scratch: np.ndarray) -> float:
    """Ψ(F) [J/m³] of the material ``params`` (:func:`material_parameters`); ``scratch`` ``(5, 3, 3)``."""
    mu, lam, alpha = params[1], params[2], params[3]
    j = _det3(f)
    if params[0] == 1.0:
        u, vt, r = scratch[0], scratch[1], scratch[2]
        sigma = scratch[3, 0]
        _rotation(f, u, sigma, vt, r)
        distance = 0.0
        for i in range(3):
            for k in range(3):
                distance += (f[i, k] - r[i, k]) ** 2
        return mu * distance + 0.5 * lam * (j - 1.0) ** 2
    ic = 0.0
    for i in range(3):
        for k in range(3):
            ic += f[i, k] * f[i, k]
    at_rest = 0.5 * lam * (1.0 - alpha) ** 2 - 0.5 * mu * np.log(4.0)  # so that Ψ(I) = 0
    return 0.5 * mu * (ic - 3.0) + 0.5 * lam * (j - alpha) ** 2 - 0.5 * mu * np.log(ic + 1.0) - at_rest


@njit(cache=True)
def piola_stress(f: np.ndarray, params: np.ndarray, p: np.ndarray, scratch: np.ndarray) -> None:
    """P = ∂Ψ/∂F [Pa] into ``p`` ``(3, 3)``; ``scratch`` ``(5, 3, 3)``."""
    mu, lam, alpha = params[1], params[2], params[3]
    cof = scratch[4]
    _cofactor(f, cof)
    j = f[0, 0] * cof[0, 0] + f[0, 1] * cof[0, 1] + f[0, 2] * cof[0, 2]
    if params[0] == 1.0:
        u, vt, r = scratch[0], scratch[1], scratch[2]
        _rotation(f, u, scratch[3, 0], vt, r)
        for i in range(3):
            for k in range(3):
                p[i, k] = 2.0 * mu * (f[i, k] - r[i, k]) + lam * (j - 1.0) * cof[i, k]
        return
    ic = 0.0
    for i in range(3):
        for k in range(3):
            ic += f[i, k] * f[i, k]
    shear = mu * (1.0 - 1.0 / (ic + 1.0))
    for i in range(3):
        for k in range(3):
            p[i, k] = shear * f[i, k] + lam * (j - alpha) * cof[i, k]


@njit(cache=True)
def stress_tangent(f: np.ndarray, params: np.ndarray, a: np.ndarray, scratch: np.ndarray) -> None:
    """A = ∂P/∂F [Pa] into ``a`` ``(9, 9)`` (exact; :func:`project_psd` makes it positive semi-definite)."""
    mu, lam, alpha = params[1], params[2], params[3]
    cof = scratch[4]
    _cofactor(f, cof)
    j = f[0, 0] * cof[0, 0] + f[0, 1] * cof[0, 1] + f[0, 2] * cof[0, 2]
    a[:, :] = 0.0
    if params[0] == 1.0:
        u, vt, r = scratch[0], scratch[1], scratch[2]
        sigma = scratch[3, 0]
        _rotation(f, u, sigma, vt, r)
        for q in range(9):
            a[q, q] = 2.0 * mu
        # dR = U Ω Vᵀ with Ω_ab = (M_ab − M_ba)/(σ_a + σ_b), M = Uᵀ dF V, for each unit dF = e_j e_lᵀ.
        for j_ in range(3):
            for l in range(3):
                for x in range(3):
                    for y in range(3):
                        if x == y:
                            continue
                        m_xy = u[j_, x] * vt[y, l]
                        m_yx = u[j_, y] * vt[x, l]
                        omega = (m_xy - m_yx) / max(sigma[x] + sigma[y], SINGULAR_FLOOR)
                        for i in range(3):
                            for k in range(3):
                                a[3 * i + k, 3 * j_ + l] -= 2.0 * mu * u[i, x] * omega * vt[y, k]
        volumetric = lam * (j - 1.0)
    else:
        ic = 0.0
        for i in range(3):
            for k in range(3):
                ic += f[i, k] * f[i, k]
        shear = mu * (1.0 - 1.0 / (ic + 1.0))
        bend = 2.0 * mu / (ic + 1.0) ** 2
        for q in range(9):
            a[q, q] = shear
            for s in range(9):
                a[q, s] += bend * f[q // 3, q % 3] * f[s // 3, s % 3]
        volumetric = lam * (j - alpha)
    for q in range(9):
        for s in range(9):
            a[q, s] += lam * cof[q // 3, q % 3] * cof[s // 3, s % 3]
    _add_determinant_hessian(f, volumetric, a)


@njit(cache=True)
def project_psd(a: np.ndarray) -> None:
    """``a`` ``(9, 9)`` symmetrised and replaced by its nearest positive semi-definite matrix (negative eigenvalues
    clamped to 0, Teran et al. 2005): a Newton direction that always descends. Unchanged where A is already PSD."""
    sym = 0.5 * (a + a.T)
    values, vectors = np.linalg.eigh(sym)
    if values[0] >= 0.0:
        a[:, :] = sym
        return
    for q in range(9):
        if values[q] < 0.0:
            values[q] = 0.0
    a[:, :] = (vectors * values) @ vectors.T


# ------------------------------------------------------------------------------------------ all elements at once
# Elements of w nodes (4: linear tets, 10: quadratic ones) integrated at q points: ``elements`` ``(m, w) int``,
# ``gradients`` ``(m, q, w, 3)`` rest shape-function gradients [1/m] at each point, ``weights`` ``(m, q)`` [m³] (a
# linear tet: q = 1, its volume; quadratic ones: :func:`.hyperelastic_quadratic.quadrature_gradients`).

@njit(cache=True)
def _deformation_gradient(x, elements, gradients, e, q, f):
    for i in range(3):
        for k in range(3):
            acc = 0.0
            for node in range(elements.shape[1]):
                acc += x[elements[e, node], i] * gradients[e, q, node, k]
            f[i, k] = acc


@njit(cache=True)
def element_energy(x: np.ndarray, elements: np.ndarray, gradients: np.ndarray, weights: np.ndarray,
                   params: np.ndarray) -> float:
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
def internal_forces(x: np.ndarray, elements: np.ndarray, gradients: np.ndarray, weights: np.ndarray,
                    params: np.ndarray, out: np.ndarray) -> None:
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
def element_tangents(x: np.ndarray, elements: np.ndarray, gradients: np.ndarray, weights: np.ndarray,
                     params: np.ndarray, project: bool, out: np.ndarray) -> None:
    """``out`` ``(m, 3w, 3w)``: K_e[3a + i, 3b + j] = Σ_q w_q Σ_kl A_q[3i + k, 3j + l] ∇N_a,k ∇N_b,l [N/m], each A
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
