"""The surface layer in finite strain: its nonlinear static equilibrium and a nonlinear implicit step.

The XPBD form's constraints are an elastic energy (Macklin et al. 2016): U(x) = Σ_c C_c(x)²/(2 α_c), with stretch
C = |x_i − x_j| − l (eq 8, compliance α [m/N]) and the signed bending angle C = β − β0 (eq 10 in the signed form of
:func:`tissuesim.pbd.constraints.signed_bend_angle`, α [1/(N·m)]). :mod:`tissuesim.pbd.static` linearises U at rest,
which is exact only while edges and hinges turn by small angles: a rotated layer gains strain energy there (a rigid
turn by θ stretches every edge by about θ²/2 of its length). Here C and ∇C are the true nonlinear ones at the
current positions, so a rigid motion costs no energy, whatever its size.

* :meth:`FiniteLayer.static`: the equilibrium ∇U(x) = f on the free nodes, by Newton's method with the consistent
  tangent H = Jᵀ α⁻¹ J + Σ_c (C_c/α_c) ∇²C_c and a backtracking line search on the total potential Π = U − fᵀx.
  Where H is not positive definite (compressed edges, hinges bent against their rest angle), that iteration uses
  the Gauss–Newton matrix Jᵀ α⁻¹ J at the current x instead, which is positive semi-definite. The hinge's ∇²β is
  the complex-step derivative (Squire & Trapp 1998) of the closed-form ∇β: exact to round-off, no step to tune.
* :meth:`FiniteLayer.implicit_step`: the interactive path. Implicit Euler of the nonlinear layer, solved by a fixed
  number of iterations with the constant matrix M/dt² + K_ff(rest) (factorised once per dt, as
  :meth:`LayerStatics.implicit_step`'s): each iteration removes the part of the residual the rest stiffness sees;
  what is left (the rotation of the stiffness) carries into the next step. At rest under a constant load its fixed
  point is :meth:`FiniteLayer.static`'s equilibrium, whatever dt, mass or iteration count.

Only the signed bending form is provided (the hybrid's xpbd layer uses it: smooth at flat hinges, where eq 10's
unsigned angle has a cusp, and so twice differentiable as Newton needs).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from numba import njit

from ..errors import SolverError
from ..fem.linear import factorise_spd
from .kernels import TINY_LENGTH, _bend_gradient_signed
from .static import LayerStatics, layer_stiffness

# Residual tolerance relative to the load the layer carries (applied forces plus reactions): Newton's last step
# takes the residual far below it, and 1e-8 keeps the position error below 1e-8 of the displacement.
STATIC_TOLERANCE = 1e-8
# Absolute floor, as a fraction of the layer's force unit (every edge at 100 % strain): ~1,000 × the round-off in
# ∇U, so an unloaded layer (a rigid motion of its supports) still converges.
FORCE_FLOOR = 1e-12
STATIC_ITERATIONS = 50
# Backtracking: Armijo's sufficient decrease; a step shorter than this fraction of Newton's means no descent.
ARMIJO = 1e-4
SHORTEST_STEP = 1e-10
# A change of Π (or of the step's incremental potential) below this many round-offs of U cannot be measured.
ROUNDOFF = 1e3 * np.finfo(np.float64).eps
# Complex step, relative to the hinge edge's length: any size far below 1 is exact to round-off.
COMPLEX_STEP = 1e-20


# ---------------------------------------------------------------- energy, forces, tangent

@njit(cache=True)
def layer_energy_gradient(x, edges, rest_length, stretch_compliance, hinges, rest_angle, bend_compliance, out):
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
        valid, beta, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z = _bend_gradient_signed(
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
    minus their sum): :func:`kernels._bend_gradient_signed`'s closed form without atan2 or branches, so that it
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
def layer_tangent(x, edges, rest_length, stretch_compliance, hinges, rest_angle, bend_compliance, gauss_newton,
                  stretch_slots, hinge_slots, data):
    """The layer's tangent at ``x`` ``(n, 3)`` [m] into the 3×3 blocks ``data`` ``(m, 3, 3)`` [N/m] of a block-sparse
    matrix, in place: Jᵀ α⁻¹ J, plus Σ (C/α) ∇²C unless ``gauss_newton``. ``stretch_slots`` ``(e, 4)`` and
    ``hinge_slots`` ``(b, 16)`` give the block of each node pair (ii, ij, ji, jj; row-major over the hinge's 4×4
    pairs), −1 where either node is prescribed."""
    data[:] = 0.0
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
        geometric = 0.0 if gauss_newton else (length - rest_length[c]) / length
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
    hessian = np.empty((12, 12))
    gradient = np.empty(12)
    work = np.empty(9, dtype=np.complex128)
    for c in range(hinges.shape[0]):
        i1 = hinges[c, 0]
        i2 = hinges[c, 1]
        i3 = hinges[c, 2]
        i4 = hinges[c, 3]
        valid, beta, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z = _bend_gradient_signed(
            x, i1, i2, i3, i4)
        if not valid:
            continue
        gradient[0], gradient[1], gradient[2], gradient[3], gradient[4], gradient[5] = g1x, g1y, g1z, g2x, g2y, g2z
        gradient[6], gradient[7], gradient[8], gradient[9], gradient[10], gradient[11] = g3x, g3y, g3z, g4x, g4y, g4z
        inverse = 1.0 / bend_compliance[c]
        if gauss_newton:
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
def _predict(positions, velocities, old, predicted, free, prescribed, targets, dt, keep):
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
def _inertial_residual(positions, predicted, free, inertia, forces, gradient, out):
    """``out`` ``(3f,)`` = M/dt² (x_pred − x) + f − ∇U on the free dofs [N]."""
    for r in range(free.shape[0]):
        i = free[r]
        for k in range(3):
            row = 3 * r + k
            out[row] = inertia[row] * (predicted[r, k] - positions[i, k]) + forces[i, k] - gradient[i, k]


@njit(cache=True)
def _descent(positions, predicted, free, inertia, forces, gradient, correction):
    """Along Δx = ``correction`` ``(3f,)``, the incremental potential E(x) = ½ |x − x_pred|²_M/dt² + U(x) − f_fᵀx_f
    changes by U(x + sΔx) − U(x) + s a + ½ s² q. Returns ``(a, q, dE/ds at 0)`` [J]."""
    linear = 0.0
    quadratic = 0.0
    slope = 0.0
    for r in range(free.shape[0]):
        i = free[r]
        for k in range(3):
            row = 3 * r + k
            d = correction[row]
            pull = inertia[row] * (positions[i, k] - predicted[r, k]) - forces[i, k]
            linear += d * pull
            quadratic += inertia[row] * d * d
            slope += d * (pull + gradient[i, k])
    return linear, quadratic, slope


@njit(cache=True)
def _advance(positions, free, correction, step, out):
    """``out`` = ``positions`` with x_f + ``step`` × ``correction`` ``(3f,)`` on the free nodes."""
    out[:] = positions
    for r in range(free.shape[0]):
        i = free[r]
        for k in range(3):
            out[i, k] += step * correction[3 * r + k]


@njit(cache=True)
def _velocities(positions, velocities, old, dt):
    """v = (x − x_old)/dt on every node."""
    inv_dt = 1.0 / dt
    for i in range(positions.shape[0]):
        for k in range(3):
            velocities[i, k] = (positions[i, k] - old[i, k]) * inv_dt


# ---------------------------------------------------------------- the solver

def _block_pattern(node_count, free_nodes, edges, hinges):
    """Block-sparse pattern of the tangent's free-free part (3×3 blocks, free nodes in :attr:`free_nodes` order).

    Returns ``(indptr (f + 1,), indices (m,), stretch_slots (e, 4), hinge_slots (b, 16))``: the BSR row pointers
    and block columns, and the block of each constraint's node pairs (−1 where a node is prescribed)."""
    index = np.full(node_count, -1, dtype=np.int64)
    index[free_nodes] = np.arange(free_nodes.size)
    f = max(free_nodes.size, 1)
    pairs = []
    for nodes, count in ((edges, 2), (hinges, 4)):
        rows = index[nodes[:, np.repeat(np.arange(count), count)]]
        cols = index[nodes[:, np.tile(np.arange(count), count)]]
        pairs.append((rows, cols, (rows >= 0) & (cols >= 0)))
    keys = np.unique(np.concatenate([(rows * f + cols)[valid] for rows, cols, valid in pairs]))
    slots = [np.where(valid, np.searchsorted(keys, rows * f + cols), -1) for rows, cols, valid in pairs]
    indptr = np.searchsorted(keys // f, np.arange(free_nodes.size + 1))
    return indptr, keys % f, slots[0], slots[1]


class FiniteLayer(LayerStatics):
    """The surface layer's finite-strain equilibrium and implicit step, some nodes prescribed (module docstring).

    Args:
        rest_positions: ``(n, 3)`` rest positions [m] (where the linearised stiffness of the interactive step is
            taken).
        edges, rest_length, stretch_compliance: ``(e, 2) int``, ``(e,)`` [m], ``(e,)`` [m/N] stretch constraints.
        hinges, rest_angle, bend_compliance: ``(b, 4) int``, ``(b,)`` signed rest angles β0 [rad], ``(b,)``
            [1/(N·m)] bending constraints.
        prescribed: ``(k,) int`` nodes whose positions are given.

    Compliances must be positive (an inextensible constraint has no energy). :meth:`displacement` (inherited) is the
    linearised answer, a good start for :meth:`static`. :attr:`gauss_newton_steps` counts the Newton iterations
    that fell back to the Gauss–Newton matrix.
    """

    def __init__(self, rest_positions, *, edges, rest_length, stretch_compliance, hinges, rest_angle,
                 bend_compliance, prescribed):
        rest = np.ascontiguousarray(rest_positions, dtype=np.float64)
        edges = np.ascontiguousarray(edges, dtype=np.int64).reshape(-1, 2)
        hinges = np.ascontiguousarray(hinges, dtype=np.int64).reshape(-1, 4)
        arrays = {}
        for name, value, count in (("rest_length", rest_length, len(edges)),
                                   ("stretch_compliance", stretch_compliance, len(edges)),
                                   ("rest_angle", rest_angle, len(hinges)),
                                   ("bend_compliance", bend_compliance, len(hinges))):
            arrays[name] = np.ascontiguousarray(value, dtype=np.float64)
            if arrays[name].shape != (count,):
                raise SolverError(f"{name} has shape {arrays[name].shape}; expected ({count},), one per constraint")
        for name in ("stretch_compliance", "bend_compliance"):
            bad = np.flatnonzero(~(arrays[name] > 0.0))
            if bad.size:
                raise SolverError(f"{bad.size} {name} values are not positive (first at {bad[:3].tolist()}); the "
                                  "finite-strain layer needs a finite stiffness for every constraint")
        super().__init__(layer_stiffness(rest, edges=edges, stretch_compliance=arrays["stretch_compliance"],
                                         hinges=hinges, bend_compliance=arrays["bend_compliance"]),
                         prescribed=prescribed)
        self._constraints = (edges, arrays["rest_length"], arrays["stretch_compliance"], hinges,
                             arrays["rest_angle"], arrays["bend_compliance"])
        self._force_unit = float(np.linalg.norm(arrays["rest_length"] / arrays["stretch_compliance"]))
        self._indptr, self._indices, self._stretch_slots, self._hinge_slots = _block_pattern(
            len(rest), self.free_nodes, edges, hinges)
        self._blocks = np.zeros((self._indices.size, 3, 3))
        # buffers: ∇U at the current and the trial positions, trial positions, the step's start and prediction
        self._gradient, self._trial_gradient = np.zeros_like(rest), np.zeros_like(rest)
        self._trial, self._old = np.zeros_like(rest), np.zeros_like(rest)
        self._predicted = np.zeros((self.free_nodes.size, 3))
        self._no_inertia = np.zeros(3 * self.free_nodes.size)  # the static solve's line search is on Π
        self.gauss_newton_steps = 0

    def energy(self, positions: np.ndarray) -> float:
        """The layer's elastic energy U [J] at ``positions`` ``(n, 3)`` [m]."""
        return layer_energy_gradient(positions, *self._constraints, self._trial_gradient)

    def static(self, positions: np.ndarray, forces: np.ndarray, targets: np.ndarray, *,
               tolerance: float = STATIC_TOLERANCE, max_iterations: int = STATIC_ITERATIONS) -> int:
        """Put ``positions`` ``(n, 3)`` [m] at the equilibrium ∇U(x) = f of the free nodes, in place; returns the
        number of Newton iterations.

        ``forces`` ``(n, 3)`` [N] (rows of prescribed nodes are not used); the prescribed nodes are put at
        ``targets`` ``(k, 3)`` [m], in :attr:`prescribed` order. Starts from ``positions``. Converged when the free
        residual |f − ∇U| ≤ ``tolerance`` × (|f_f| + |reactions|) + FORCE_FLOOR × the layer's force unit. Raises
        SolverError, with ``positions`` unchanged, when it does not converge in ``max_iterations``, when no step
        along Newton's direction lowers the potential, or when the layer does not hold every free node.
        """
        x = np.array(positions, dtype=np.float64)
        x[self.prescribed] = targets
        load = np.ascontiguousarray(forces[self.free_nodes], dtype=np.float64)
        for iteration in range(max_iterations + 1):
            energy = layer_energy_gradient(x, *self._constraints, self._gradient)
            gradient = self._gradient
            residual = load - gradient[self.free_nodes]
            norm = float(np.linalg.norm(residual))
            limit = (tolerance * (np.linalg.norm(load) + np.linalg.norm(gradient[self.prescribed]))
                     + FORCE_FLOOR * self._force_unit)
            if norm <= limit:
                positions[:] = x
                return iteration
            if iteration < max_iterations:
                self._line_search(x, self._newton_direction(x, residual), energy, forces)
        raise SolverError(
            f"the surface layer's finite-strain equilibrium did not converge in {max_iterations} Newton iterations "
            f"(free residual {norm:.3g} N, tolerance {limit:.3g} N, load {np.linalg.norm(load):.3g} N); the load "
            "may be beyond what the layer carries: lower it, or apply it in steps from the last converged state, "
            "or raise max_iterations")

    def tangent(self, positions: np.ndarray, *, gauss_newton: bool = False) -> sp.csc_matrix:
        """``(3f, 3f)`` free-free part [N/m] of the layer's tangent at ``positions`` ``(n, 3)`` [m], free dofs in
        :attr:`free_nodes` order: Newton's Jᵀ α⁻¹ J + Σ (C/α) ∇²C, or with ``gauss_newton`` only Jᵀ α⁻¹ J."""
        layer_tangent(positions, *self._constraints, gauss_newton, self._stretch_slots, self._hinge_slots,
                      self._blocks)
        size = 3 * self.free_nodes.size
        return sp.bsr_matrix((self._blocks, self._indices, self._indptr), shape=(size, size)).tocsc()

    def _newton_direction(self, x: np.ndarray, residual: np.ndarray) -> np.ndarray:
        """``(3f,)`` Newton step H⁻¹ r, with the Gauss–Newton matrix where H is not positive definite."""
        for gauss_newton in (False, True):
            try:
                factor = factorise_spd(self.tangent(x, gauss_newton=gauss_newton), self._dof_node)
            except SolverError:
                if not gauss_newton:
                    continue
                raise SolverError("the surface layer does not hold every free node (its Gauss–Newton matrix is "
                                  "singular): a cut may have left a flap that only its inertia holds (use the "
                                  "implicit step), or a triangle has collapsed (start from a less deformed state, "
                                  "e.g. the linear answer)") from None
            self.gauss_newton_steps += gauss_newton
            return np.asarray(factor.solve(residual.ravel()))

    def _line_search(self, x: np.ndarray, direction: np.ndarray, energy: float, forces: np.ndarray) -> None:
        """Move ``x`` (U = ``energy``, ∇U in the buffer) in place along ``direction`` ``(3f,)`` on the free nodes,
        as far as lowers Π = U − f_fᵀx_f (:meth:`_backtrack`); raises SolverError if no step does."""
        if self._backtrack(x, direction, energy, self._no_inertia, forces) is None:
            raise SolverError(
                "the surface layer's finite-strain solve found no step that lowers its potential; the layer may be "
                "tangled (a hinge folded through itself): start from a less deformed state or apply the load in "
                "steps")
        x[:] = self._trial

    def _backtrack(self, x, direction, energy, inertia, forces) -> float | None:
        """Backtracking along ``direction`` ``(3f,)`` from ``x`` (U = ``energy``, ∇U in the buffer) on the
        incremental potential E = ½ |x − x_pred|²_M/dt² + U − f_fᵀx_f (``inertia`` M/dt² ``(3f,)``; zero: Π).

        Returns U at the longest s = 2⁻ᵏ ≥ SHORTEST_STEP that meets Armijo's condition, its positions and ∇U left
        in the trial buffers, or None. Near a minimum, E's change falls below U's round-off and cannot be
        measured; there the step must instead not raise E's slope above its magnitude at s = 0 (Hager & Zhang
        2005's approximate Armijo condition, the same test for a quadratic)."""
        free, predicted = self.free_nodes, self._predicted
        linear, quadratic, slope = _descent(x, predicted, free, inertia, forces, self._gradient, direction)
        step = 1.0
        while step >= SHORTEST_STEP:
            _advance(x, free, direction, step, self._trial)
            trial_energy = layer_energy_gradient(self._trial, *self._constraints, self._trial_gradient)
            change = trial_energy - energy + step * linear + 0.5 * step * step * quadratic
            if change <= ARMIJO * step * slope:
                return trial_energy
            if abs(change) <= ROUNDOFF * energy:
                trial_slope = _descent(self._trial, predicted, free, inertia, forces, self._trial_gradient,
                                       direction)[2]
                if trial_slope <= (2.0 * ARMIJO - 1.0) * slope:
                    return trial_energy
            step *= 0.5
        return None

    def implicit_step(self, positions: np.ndarray, velocities: np.ndarray, rest: np.ndarray, forces: np.ndarray,
                      targets: np.ndarray, mass: np.ndarray, dt: float, damping: float, *,
                      iterations: int = 2) -> None:
        """One implicit-Euler step of the nonlinear layer, in place on ``positions``, ``velocities`` ``(n, 3)``.

        Minimises the incremental potential E(x) = ½ |x − x_pred|²_M/dt² + U(x) − f_fᵀx_f, x_pred = x + dt
        (1 − damping) v, whose stationary point is implicit Euler's M/dt² (x − x_pred) + ∇U_f(x) = f_f, by
        ``iterations`` corrections (M/dt² + K_ff(rest)) Δx = −∇E from x = x_pred, each with a backtracking line
        search on E: the constant matrix is positive definite, so Δx always descends, and the search keeps a large
        rotation (where K(rest) is the wrong stiffness) from overshooting. ``forces`` ``(n, 3)`` [N], lumped
        ``mass`` ``(n,)`` [kg], prescribed nodes at ``targets`` ``(k, 3)`` [m]; v = Δx/dt. The matrix is
        factorised once per dt (as :meth:`LayerStatics.implicit_step`'s, whose arguments these are; ``rest`` is
        not needed: the layer's rest state is in its rest lengths and angles). With CHOLMOD a step allocates
        nothing."""
        free = self.free_nodes
        _predict(positions, velocities, self._old, self._predicted, free, self.prescribed, targets, dt,
                 1.0 - damping)
        if free.size:
            if self._dynamic is None or self._dynamic[0] != dt:
                self._dynamic = (dt, *self._dynamic_factor(mass, dt))
            self._relax(positions, forces, iterations)
        _velocities(positions, velocities, self._old, dt)

    def _relax(self, positions: np.ndarray, forces: np.ndarray, iterations: int) -> None:
        """The implicit step's ``iterations`` line-searched corrections of ``positions``, in place."""
        _, factor, inertia, buffer, rhs = self._dynamic
        energy = layer_energy_gradient(positions, *self._constraints, self._gradient)
        for _ in range(iterations):
            _inertial_residual(positions, self._predicted, self.free_nodes, inertia, forces, self._gradient, rhs)
            if buffer is None:
                correction = np.asarray(factor.solve(rhs))
            else:
                factor.solve_in_place(buffer)
                correction = rhs
            trial_energy = self._backtrack(positions, correction, energy, inertia, forces)
            if trial_energy is None:  # no measurable descent left: converged as far as round-off allows
                return
            positions[:] = self._trial
            self._gradient, self._trial_gradient = self._trial_gradient, self._gradient
            energy = trial_energy
