"""The surface layer in finite strain: its nonlinear static equilibrium and a nonlinear implicit step.

The XPBD form's constraints are an elastic energy (Macklin et al. 2016): U(x) = Σ_c C_c(x)²/(2 α_c), with stretch
C = |x_i − x_j| − l (eq 8, compliance α [m/N]) and the signed bending angle C = β − β0 (eq 10 in the signed form of
:func:`tissuesim.layer.constraints.signed_bend_angle`, α [1/(N·m)]). :mod:`tissuesim.layer.static` linearises U at rest,
which is exact only while edges and hinges turn by small angles: a rotated layer gains strain energy there (a rigid
turn by θ stretches every edge by about θ²/2 of its length). Here C and ∇C are the true nonlinear ones at the
current positions, so a rigid motion costs no energy, whatever its size.

* :meth:`FiniteLayer.static`: the equilibrium ∇U(x) = f on the free nodes, by Newton's method with the consistent
  tangent H = Jᵀ α⁻¹ J + Σ_c (C_c/α_c) ∇²C_c and a backtracking line search on the total potential Π = U − fᵀx.
  The hinge's ∇²β is the complex-step derivative (Squire & Trapp 1998) of the closed-form ∇β: exact to round-off,
  no step to tune. Where H is not positive definite (compressed edges, the hinges' curvature terms), that iteration
  uses the part of H that is positive semi-definite at any x instead: Gauss–Newton's Jᵀ α⁻¹ J plus the geometric
  stiffness of the stretched edges, which holds a pulled membrane sideways as its tension does. Measured on the
  hybrid cube's layer (1,352 nodes, 647 prescribed at the FEM's answer), 1 N on the top node: 6 iterations from the
  linear answer, none of them a fallback (Gauss–Newton's matrix alone: 71); 5 N: 6 from the linear answer, 8 from
  rest (46 with Gauss–Newton's matrix as the fallback; Gauss–Newton alone did not converge in 200).
* :meth:`FiniteLayer.implicit_step`: the interactive path. Implicit Euler of the nonlinear layer, solved by a fixed
  number of iterations with the constant matrix M/dt² + K_ff(rest) (factorised once per dt, as
  :meth:`LayerStatics.implicit_step`'s), each line-searched on the step's incremental potential: the matrix is
  positive definite, so its correction always descends, and the search stops it overshooting where the layer has
  turned far from rest and K(rest) is the wrong stiffness (without it the step diverged within 5 steps under 1 N on
  a cube corner; with it, while the layer moved, the accepted fraction of the correction was 0.05–0.5, so each
  iteration starts its search where the last step found the minimum). What one step leaves carries into the next.
  At rest under a constant load its fixed point is :meth:`FiniteLayer.static`'s equilibrium, whatever dt, mass or
  iteration count. A step costs 3–4 evaluations of U and ∇U and two back-substitutions, against LayerStatics' one
  back-substitution: about 4× its time on the hybrid cube while the layer moves under 1 N.

Only the signed bending form is provided (the hybrid's xpbd layer uses it: smooth at flat hinges, where eq 10's
unsigned angle has a cusp, and so twice differentiable as Newton needs).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike

from ..errors import SolverError, first_indices
from ..fem.factorise import factorise_spd
from .finite_kernels import (layer_energy_gradient, layer_tangent, step_advance, step_descent, step_predict,
                             step_residual, step_velocities)
from .static import LayerStatics, layer_stiffness

# Residual tolerance relative to the load the layer carries (applied forces plus reactions): Newton's last step
# takes the residual far below it, and 1e-8 keeps the position error below 1e-8 of the displacement.
STATIC_TOLERANCE = 1e-8
# Absolute floor, as a fraction of the layer's force unit (every edge at 100 % strain): ~1,000 × the round-off in
# ∇U, so an unloaded layer (a rigid motion of its supports) still converges.
FORCE_FLOOR = 1e-12
STATIC_ITERATIONS = 50
# Backtracking: Armijo's sufficient decrease, E(s) − E(0) ≤ c s E'(0). With c = 1/4 a step may overshoot E's
# minimum along the line by at most half (exactly so on a quadratic): the implicit step's constant matrix is not the
# tangent, and c = 1e-4 let it overshoot nearly twofold, so that a soft mode rang from step to step. Newton's own
# steps pass it (c < 1/2). Where E's change is below round-off, the slope test: E'(s) ≤ (1 − 2c) |E'(0)|.
SUFFICIENT_DECREASE = 0.25
DECREASE_SLOPE = 1.0 - 2.0 * SUFFICIENT_DECREASE
# A step shorter than this fraction of the first means no descent.
SHORTEST_STEP = 1e-10
# A change of E (Π, or the step's incremental potential) below this many round-offs cannot be measured.
ROUNDOFF = 1e3 * np.finfo(np.float64).eps


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


def _checked_constraints(edge_count: int, hinge_count: int, **values) -> dict:
    """The per-constraint arrays ``values`` as ``(e,)`` or ``(b,)`` float64 (``rest_length`` and
    ``stretch_compliance`` per edge, the others per hinge); SolverError for a wrong shape or a compliance ≤ 0."""
    arrays = {}
    for name, value in values.items():
        count = edge_count if name in ("rest_length", "stretch_compliance") else hinge_count
        arrays[name] = np.ascontiguousarray(value, dtype=np.float64)
        if arrays[name].shape != (count,):
            raise SolverError(f"{name} has shape {arrays[name].shape}; expected ({count},), one per constraint")
        bad = np.flatnonzero(~(arrays[name] > 0.0))
        if name.endswith("compliance") and bad.size:
            raise SolverError(f"{bad.size} {name} values are not positive (first: {first_indices(bad)}); the "
                              "finite-strain layer needs a finite stiffness for every constraint")
    return arrays


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
    linearised answer, a good start for :meth:`static`. :attr:`definite_steps` counts the Newton iterations that
    fell back to the definite part of the tangent.
    """

    def __init__(self, rest_positions: ArrayLike, *, edges: ArrayLike, rest_length: ArrayLike,
                 stretch_compliance: ArrayLike, hinges: ArrayLike, rest_angle: ArrayLike, bend_compliance: ArrayLike,
                 prescribed: ArrayLike):
        rest = np.ascontiguousarray(rest_positions, dtype=np.float64)
        edges = np.ascontiguousarray(edges, dtype=np.int64).reshape(-1, 2)
        hinges = np.ascontiguousarray(hinges, dtype=np.int64).reshape(-1, 4)
        arrays = _checked_constraints(len(edges), len(hinges), rest_length=rest_length,
                                      stretch_compliance=stretch_compliance, rest_angle=rest_angle,
                                      bend_compliance=bend_compliance)
        super().__init__(layer_stiffness(rest, edges=edges, stretch_compliance=arrays["stretch_compliance"],
                                         hinges=hinges, bend_compliance=arrays["bend_compliance"]),
                         prescribed=prescribed)
        self._constraints = (edges, arrays["rest_length"], arrays["stretch_compliance"], hinges,
                             arrays["rest_angle"], arrays["bend_compliance"])
        # the step needs only the constraints that move with a free node (those among prescribed nodes alone add a
        # constant to U and nothing to ∇U_f): a third fewer on the hybrid cube
        moves = np.ones(len(rest), dtype=bool)
        moves[self.prescribed] = False
        keep_edges, keep_hinges = moves[edges].any(axis=1), moves[hinges].any(axis=1)
        self._moving = tuple(np.ascontiguousarray(a[keep]) for a, keep in zip(
            self._constraints, (keep_edges, keep_edges, keep_edges, keep_hinges, keep_hinges, keep_hinges)))
        self._force_unit = float(np.linalg.norm(arrays["rest_length"] / arrays["stretch_compliance"]))
        self._indptr, self._indices, self._stretch_slots, self._hinge_slots = _block_pattern(
            len(rest), self.free_nodes, edges, hinges)
        self._blocks = np.zeros((self._indices.size, 3, 3))
        # buffers: ∇U at the current and the trial positions, trial positions, the step's start and prediction
        self._gradient, self._trial_gradient = np.zeros_like(rest), np.zeros_like(rest)
        self._trial, self._old = np.zeros_like(rest), np.zeros_like(rest)
        self._predicted = np.zeros((self.free_nodes.size, 3))
        self._no_inertia = np.zeros(3 * self.free_nodes.size)  # the static solve's line search is on Π
        self.definite_steps = 0
        self._first_steps = []  # the implicit step's first trial step per iteration (see _relax)

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

    def tangent(self, positions: np.ndarray, *, definite: bool = False) -> sp.csc_matrix:
        """``(3f, 3f)`` free-free part [N/m] of the layer's tangent at ``positions`` ``(n, 3)`` [m], free dofs in
        :attr:`free_nodes` order: Newton's Jᵀ α⁻¹ J + Σ (C/α) ∇²C, or with ``definite`` its part that is positive
        semi-definite at any x (:func:`~tissuesim.layer.finite_kernels.layer_tangent`)."""
        layer_tangent(positions, *self._constraints, definite, self._stretch_slots, self._hinge_slots, self._blocks)
        size = 3 * self.free_nodes.size
        return sp.bsr_matrix((self._blocks, self._indices, self._indptr), shape=(size, size)).tocsc()

    def _newton_direction(self, x: np.ndarray, residual: np.ndarray) -> np.ndarray:
        """``(3f,)`` Newton step H⁻¹ r, with H's definite part where H is not positive definite."""
        try:
            factor = factorise_spd(self.tangent(x), self.dof_node)
        except SolverError:
            self.definite_steps += 1
            try:
                factor = factorise_spd(self.tangent(x, definite=True), self.dof_node)
            except SolverError:
                raise SolverError("the surface layer does not hold every free node (even the definite part of its "
                                  "tangent is singular): a cut may have left a flap that only its inertia holds (use "
                                  "the implicit step), or a triangle has collapsed (start from a less deformed "
                                  "state, e.g. the linear answer)") from None
        return np.asarray(factor.solve(residual.ravel()))

    def _line_search(self, x: np.ndarray, direction: np.ndarray, energy: float, forces: np.ndarray) -> None:
        """Move ``x`` (U = ``energy``, ∇U in the buffer) in place along ``direction`` ``(3f,)`` on the free nodes,
        as far as lowers Π = U − f_fᵀx_f (:meth:`_backtrack`); raises SolverError if no step does."""
        if self._backtrack(x, direction, energy, self._no_inertia, forces, self._constraints) is None:
            raise SolverError(
                "the surface layer's finite-strain solve found no step that lowers its potential; the layer may be "
                "tangled (a hinge folded through itself): start from a less deformed state or apply the load in "
                "steps")
        x[:] = self._trial

    def _backtrack(self, x, direction, energy, inertia, forces, constraints, first=1.0) -> tuple | None:
        """Backtracking along ``direction`` ``(3f,)`` from ``x`` (U = ``energy``, ∇U in the buffer) on the
        incremental potential E = ½ |x − x_pred|²_M/dt² + U − f_fᵀx_f (``inertia`` M/dt² ``(3f,)``; zero: Π),
        with U over ``constraints`` (those that move with the free nodes suffice: the rest is constant).

        Tries s = ``first``, then after a rejected s the secant estimate of E's minimum along the line from E's
        slopes at 0 and s, kept within [s/10, s/2]. Returns U at the first s with sufficient decrease (its positions
        and ∇U left in the trial buffers) and the secant estimate of the minimum there, or None when s falls below
        SHORTEST_STEP or E's slope at 0 is within its round-off (nothing to gain). Near a minimum, E's change falls
        below U's round-off and cannot be measured; there the slope at s must instead be below DECREASE_SLOPE of its
        magnitude at 0 (Hager & Zhang 2005's approximate Armijo condition, the same test for a quadratic)."""
        free, predicted = self.free_nodes, self._predicted
        linear, quadratic, slope, magnitude = step_descent(x, predicted, free, inertia, forces, self._gradient,
                                                           direction)
        if -slope <= ROUNDOFF * magnitude:
            return None
        step = first
        while step >= SHORTEST_STEP:
            step_advance(x, free, direction, step, self._trial)
            trial_energy = layer_energy_gradient(self._trial, *constraints, self._trial_gradient)
            change = trial_energy - energy + step * linear + 0.5 * step * step * quadratic
            trial_slope = step_descent(self._trial, predicted, free, inertia, forces, self._trial_gradient,
                                       direction)[2]
            secant = step * slope / (slope - trial_slope) if trial_slope > slope else 2.0 * step
            if change <= SUFFICIENT_DECREASE * step * slope or (
                    abs(change) <= ROUNDOFF * energy and trial_slope <= -DECREASE_SLOPE * slope):
                return trial_energy, secant
            step = min(max(secant, 0.1 * step), 0.5 * step)
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
        step_predict(positions, velocities, self._old, self._predicted, free, self.prescribed, targets, dt,
                     1.0 - damping)
        if free.size:
            if self.dynamic is None or self.dynamic[0] != dt:
                self.dynamic = (dt, *self.dynamic_factor(mass, dt))
            self._relax(positions, forces, iterations)
        step_velocities(positions, velocities, self._old, dt)

    def _balanced(self, residual: np.ndarray, forces: np.ndarray) -> bool:
        """Whether the step's ``residual`` ``(3f,)`` [N] is within :meth:`static`'s tolerance of the load."""
        load = float(np.linalg.norm(forces[self.free_nodes])) + float(np.linalg.norm(self._gradient[self.prescribed]))
        return float(np.linalg.norm(residual)) <= STATIC_TOLERANCE * load + FORCE_FLOOR * self._force_unit

    def _relax(self, positions: np.ndarray, forces: np.ndarray, iterations: int) -> None:
        """The implicit step's ``iterations`` line-searched corrections of ``positions``, in place."""
        _, factor, inertia, buffer, rhs = self.dynamic
        energy = layer_energy_gradient(positions, *self._moving, self._gradient)
        if len(self._first_steps) != iterations:
            self._first_steps = [1.0] * iterations
        for iteration in range(iterations):
            step_residual(positions, self._predicted, self.free_nodes, inertia, forces, self._gradient, rhs)
            if self._balanced(rhs, forces):   # at rest at the equilibrium (a held load): nothing to solve
                return
            if buffer is None:
                correction = np.asarray(factor.solve(rhs))
            else:
                factor.solve_in_place(buffer)
                correction = rhs
            found = self._backtrack(positions, correction, energy, inertia, forces, self._moving,
                                    self._first_steps[iteration])
            if found is None:  # no measurable descent left: converged as far as round-off allows
                return
            energy, minimum = found
            # the next step's same iteration starts at this one's estimated minimum: how far K(rest) overshoots
            # changes slowly from step to step (Nocedal & Wright 2006, §3.5's initial step)
            self._first_steps[iteration] = min(1.0, minimum)
            positions[:] = self._trial
            self._gradient, self._trial_gradient = self._trial_gradient, self._gradient
