"""Numba kernels of the finite-strain surface layer (:mod:`tissuesim.layer.finite_layer`): the energy
U = Σ_c C_c²/(2 α_c) (Macklin et al. 2016) of the stretch (eq 8) and signed bending (eq 10, signed form)
constraints, its gradient and its tangent at the current positions, and the per-dof loops of the implicit step.
Arrays are the caller's, written in place.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .hinge_kernels import TINY_LENGTH, bend_gradient_signed

# Complex step, relative to the hinge edge's length: any size far below 1 is exact to round-off.
COMPLEX_STEP = 1e-20


# ---------------------------------------------------------------- energy, forces, tangent

@njit(cache=True)
def layer_energy_gradient(x: np.ndarray, edges: np.ndarray, rest_length: np.ndarray, stretch_compliance: np.ndarray,
                          hinges: np.ndarray, rest_angle: np.ndarray, bend_compliance: np.ndarray,
                          out: np.ndarray) -> float:
    """The energy U = Σ_c C_c²/(2 α_c) [J] at positions ``x`` ``(n, 3)`` [m], returned, and its gradient
    ∇U = Σ_c (C_c/α_c) ∇C_c [N] into ``out`` ``(n, 3)`` (the layer's internal forces are −∇U). Degenerate hinges
    count zero, as in the kernels; a zero-length edge has energy but no direction, so no force."""
    out[:] = 0.0
    total = 0.0
    for c in range(edges.shape[0]):
        i = edges[c, 0]
        j = edges[c, 1]
        d0 = x[i, 0] - x[j, 0]
        d1 = x[i, 1] - x[j, 1]
        d2 = x[i, 2] - x[j, 2]
        length = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        value = length - rest_length[c]
        total += value * value / (2.0 * stretch_compliance[c])
        if length <= TINY_LENGTH:
            continue
        s = value / (stretch_compliance[c] * length)
        out[i, 0] += s * d0
        out[i, 1] += s * d1
        out[i, 2] += s * d2
        out[j, 0] -= s * d0
        out[j, 1] -= s * d1
        out[j, 2] -= s * d2
    for c in range(hinges.shape[0]):
        i1 = hinges[c, 0]
        i2 = hinges[c, 1]
        i3 = hinges[c, 2]
        i4 = hinges[c, 3]
        valid, beta, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z = bend_gradient_signed(
            x, i1, i2, i3, i4)
        if not valid:
            continue
        value = beta - rest_angle[c]
        total += value * value / (2.0 * bend_compliance[c])
        s = value / bend_compliance[c]
        out[i1, 0] += s * g1x
        out[i1, 1] += s * g1y
        out[i1, 2] += s * g1z
        out[i2, 0] += s * g2x
        out[i2, 1] += s * g2y
        out[i2, 2] += s * g2z
        out[i3, 0] += s * g3x
        out[i3, 1] += s * g3y
        out[i3, 2] += s * g3z
        out[i4, 0] += s * g4x
        out[i4, 1] += s * g4y
        out[i4, 2] += s * g4z
    return total


@njit(cache=True, inline="always")
def _hinge_gradient_abc(ax, ay, az, bx, by, bz, cx, cy, cz):
    """(∇_2β, ∇_3β, ∇_4β) of the signed angle as 9 numbers, from a = P2 − P1, b = P3 − P1, c = P4 − P1 (∇_1β is
    minus their sum): :func:`hinge_kernels.bend_gradient_signed`'s closed form without atan2 or branches, so that it
    runs on complex numbers for the complex-step Hessian."""
    nax = ay * bz - az * by
    nay = az * bx - ax * bz
    naz = ax * by - ay * bx
    nbx = cy * az - cz * ay
    nby = cz * ax - cx * az
    nbz = cx * ay - cy * ax
    length2 = ax * ax + ay * ay + az * az
    length = np.sqrt(length2)
    fa = -length / (nax * nax + nay * nay + naz * naz)
    fb = -length / (nbx * nbx + nby * nby + nbz * nbz)
    ta = (bx * ax + by * ay + bz * az) / length2
    tb = (cx * ax + cy * ay + cz * az) / length2
    return (-ta * fa * nax - tb * fb * nbx, -ta * fa * nay - tb * fb * nby, -ta * fa * naz - tb * fb * nbz,
            fa * nax, fa * nay, fa * naz, fb * nbx, fb * nby, fb * nbz)


@njit(cache=True)
def _hinge_hessian(x, i1, i2, i3, i4, work, out):
    """``out`` ``(12, 12)`` = ∇²β of a (valid) hinge over (P1, P2, P3, P4), in place; ``work`` ``(9,) complex128``.

    Column k of ∂(∇_2β, ∇_3β, ∇_4β)/∂(a, b, c) is Im ∇β(v + i h e_k)/h; P1 enters through a, b, c with sign −1, and
    ∇_1β = −Σ, so its rows and columns are minus the sums of the others'. Symmetrised against round-off."""
    for k in range(3):
        work[k] = x[i2, k] - x[i1, k]
        work[3 + k] = x[i3, k] - x[i1, k]
        work[6 + k] = x[i4, k] - x[i1, k]
    h = COMPLEX_STEP * math.sqrt(work[0].real ** 2 + work[1].real ** 2 + work[2].real ** 2)
    out[:] = 0.0
    for col in range(9):
        work[col] += 1j * h
        g = _hinge_gradient_abc(work[0], work[1], work[2], work[3], work[4], work[5], work[6], work[7], work[8])
        work[col] -= 1j * h
        for row in range(9):
            out[3 + row, 3 + col] = g[row].imag / h
    for row in range(3, 12):
        for k in range(3):
            out[row, k] = -(out[row, 3 + k] + out[row, 6 + k] + out[row, 9 + k])
    for col in range(12):
        for k in range(3):
            out[k, col] = -(out[3 + k, col] + out[6 + k, col] + out[9 + k, col])
    for row in range(12):
        for col in range(row + 1, 12):
            mean = 0.5 * (out[row, col] + out[col, row])
            out[row, col] = mean
            out[col, row] = mean


@njit(cache=True)
def layer_tangent(x: np.ndarray, edges: np.ndarray, rest_length: np.ndarray, stretch_compliance: np.ndarray,
                  hinges: np.ndarray, rest_angle: np.ndarray, bend_compliance: np.ndarray, definite: bool,
                  stretch_slots: np.ndarray, hinge_slots: np.ndarray, data: np.ndarray) -> None:
    """The layer's tangent at ``x`` ``(n, 3)`` [m] into the 3×3 blocks ``data`` ``(m, 3, 3)`` [N/m] of a block-sparse
    matrix, in place: Jᵀ α⁻¹ J + Σ (C/α) ∇²C; with ``definite``, only the parts that are positive semi-definite
    whatever x: Jᵀ α⁻¹ J and the geometric stiffness of stretched edges (C > 0), without that of compressed edges
    and of the hinges. ``stretch_slots`` ``(e, 4)`` and ``hinge_slots`` ``(b, 16)`` give the block of each node pair
    (ii, ij, ji, jj; row-major over the hinge's 4×4 pairs), −1 where either node is prescribed."""
    data[:] = 0.0
    _add_stretch_tangent(x, edges, rest_length, stretch_compliance, definite, stretch_slots, data)
    _add_hinge_tangent(x, hinges, rest_angle, bend_compliance, definite, hinge_slots, data)


@njit(cache=True)
def _add_stretch_tangent(x, edges, rest_length, stretch_compliance, definite, stretch_slots, data):
    """The stretch constraints' part of :func:`layer_tangent`, added to ``data``."""
    block = np.empty((3, 3))
    d = np.empty(3)
    for c in range(edges.shape[0]):
        i = edges[c, 0]
        j = edges[c, 1]
        for k in range(3):
            d[k] = x[i, k] - x[j, k]
        length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        if length <= TINY_LENGTH:
            continue
        d /= length
        # ∇²C of |x_i − x_j| is (I − d̂d̂ᵀ)/|d| on the ii and jj blocks, minus that on ij and ji
        geometric = (length - rest_length[c]) / length
        if definite and geometric < 0.0:
            geometric = 0.0
        for p in range(3):
            for q in range(3):
                block[p, q] = ((1.0 - geometric) * d[p] * d[q] + (geometric if p == q else 0.0)) / stretch_compliance[c]
        for pair in range(4):
            slot = stretch_slots[c, pair]
            if slot >= 0:
                sign = 1.0 if pair == 0 or pair == 3 else -1.0
                for p in range(3):
                    for q in range(3):
                        data[slot, p, q] += sign * block[p, q]


@njit(cache=True)
def _add_hinge_tangent(x, hinges, rest_angle, bend_compliance, definite, hinge_slots, data):
    """The bending constraints' part of :func:`layer_tangent`, added to ``data``."""
    hessian = np.empty((12, 12))
    gradient = np.empty(12)
    work = np.empty(9, dtype=np.complex128)
    for c in range(hinges.shape[0]):
        i1 = hinges[c, 0]
        i2 = hinges[c, 1]
        i3 = hinges[c, 2]
        i4 = hinges[c, 3]
        valid, beta, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z = bend_gradient_signed(
            x, i1, i2, i3, i4)
        if not valid:
            continue
        gradient[0], gradient[1], gradient[2], gradient[3], gradient[4], gradient[5] = g1x, g1y, g1z, g2x, g2y, g2z
        gradient[6], gradient[7], gradient[8], gradient[9], gradient[10], gradient[11] = g3x, g3y, g3z, g4x, g4y, g4z
        inverse = 1.0 / bend_compliance[c]
        if definite:
            hessian[:] = 0.0
        else:
            _hinge_hessian(x, i1, i2, i3, i4, work, hessian)
        curvature = (beta - rest_angle[c]) * inverse
        for a in range(4):
            for b in range(4):
                slot = hinge_slots[c, 4 * a + b]
                if slot < 0:
                    continue
                for p in range(3):
                    for q in range(3):
                        data[slot, p, q] += (inverse * gradient[3 * a + p] * gradient[3 * b + q]
                                             + curvature * hessian[3 * a + p, 3 * b + q])


# ---------------------------------------------------------------- the implicit step's per-dof kernels

@njit(cache=True)
def step_predict(positions: np.ndarray, velocities: np.ndarray, old: np.ndarray, predicted: np.ndarray,
                 free: np.ndarray, prescribed: np.ndarray, targets: np.ndarray, dt: float, keep: float) -> None:
    """Save ``old`` positions, set x_pred = x + dt (1 − damping) v on the free nodes (also the iterations' start)
    and put the prescribed nodes at their targets."""
    old[:] = positions
    for r in range(free.shape[0]):
        i = free[r]
        for k in range(3):
            predicted[r, k] = positions[i, k] + dt * keep * velocities[i, k]
            positions[i, k] = predicted[r, k]
    for r in range(prescribed.shape[0]):
        for k in range(3):
            positions[prescribed[r], k] = targets[r, k]


@njit(cache=True)
def step_residual(positions: np.ndarray, predicted: np.ndarray, free: np.ndarray, inertia: np.ndarray,
                  forces: np.ndarray, gradient: np.ndarray, out: np.ndarray) -> None:
    """``out`` ``(3f,)`` = M/dt² (x_pred − x) + f − ∇U on the free dofs [N]."""
    for r in range(free.shape[0]):
        i = free[r]
        for k in range(3):
            row = 3 * r + k
            out[row] = inertia[row] * (predicted[r, k] - positions[i, k]) + forces[i, k] - gradient[i, k]


@njit(cache=True)
def step_descent(positions: np.ndarray, predicted: np.ndarray, free: np.ndarray, inertia: np.ndarray,
                 forces: np.ndarray, gradient: np.ndarray, correction: np.ndarray) -> tuple[float, float, float, float]:
    """Along Δx = ``correction`` ``(3f,)``, the incremental potential E(x) = ½ |x − x_pred|²_M/dt² + U(x) − f_fᵀx_f
    changes by U(x + sΔx) − U(x) + s a + ½ s² q. Returns ``(a, q, dE/ds at 0, the sum of |terms| of that slope)``
    [J]; the last bounds the slope's round-off."""
    linear = 0.0
    quadratic = 0.0
    slope = 0.0
    magnitude = 0.0
    for r in range(free.shape[0]):
        i = free[r]
        for k in range(3):
            row = 3 * r + k
            d = correction[row]
            pull = inertia[row] * (positions[i, k] - predicted[r, k]) - forces[i, k]
            linear += d * pull
            quadratic += inertia[row] * d * d
            slope += d * (pull + gradient[i, k])
            magnitude += abs(d) * (abs(pull) + abs(gradient[i, k]))
    return linear, quadratic, slope, magnitude


@njit(cache=True)
def step_advance(positions: np.ndarray, free: np.ndarray, correction: np.ndarray, step: float,
                 out: np.ndarray) -> None:
    """``out`` = ``positions`` with x_f + ``step`` × ``correction`` ``(3f,)`` on the free nodes."""
    out[:] = positions
    for r in range(free.shape[0]):
        i = free[r]
        for k in range(3):
            out[i, k] += step * correction[3 * r + k]


@njit(cache=True)
def step_velocities(positions: np.ndarray, velocities: np.ndarray, old: np.ndarray, dt: float) -> None:
    """v = (x − x_old)/dt on every node."""
    inv_dt = 1.0 / dt
    for i in range(positions.shape[0]):
        for k in range(3):
            velocities[i, k] = (positions[i, k] - old[i, k]) * inv_dt
