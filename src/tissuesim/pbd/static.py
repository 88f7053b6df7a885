"""The surface layer's static equilibrium, solved to convergence (Gauss–Newton with a line search).

The XPBD form's constraints define an elastic energy (Macklin et al. 2016, U = Σ_c C_c²/(2 α_c)): stretch (eq 8)
and bending (eq 10) with the material's compliance α (:mod:`tissuesim.pbd.compliance`). Under external nodal
forces f, with some nodes prescribed (control nodes at their FEM positions, fixed nodes at rest), the layer's
equilibrium minimises Φ(x) = U(x) − f·x over the free nodes. It depends on the material, the geometry and f
only: not on dt, node masses, density or a sweep count, which shape the path of a time-stepped solve, not its end.

Each iteration solves H Δx = −∇Φ with H = Jᵀ α⁻¹ J (J the constraint Jacobian) plus the geometric stiffness of
the stretched springs (projected Newton: compressed springs and the hinges' second derivatives are left out, which
keeps H positive definite; that only changes the convergence rate, never the answer, because the iteration stops
on the exact gradient), then backtracks on Φ. It stops when the largest free-node force residual
|∇Φ| falls below ``rtol`` × the largest nodal load.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit

from ..errors import SolverError
from .kernels import TINY_LENGTH, _bend_gradient, _bend_gradient_signed

DEFAULT_RTOL = 1e-9
MAX_ITERATIONS = 50


@njit(cache=True)
def constraint_jacobian(x, edges, rest_length, bending, rest_angle, signed_bending, values, stretch_grad,
                        bend_grad):
    """Constraint values and gradients at positions ``x`` ``(n, 3)`` [m], in place.

    ``values``: ``(e + b,)`` C of each stretch constraint [m] then each hinge [rad]; ``stretch_grad`` ``(e, 6)``:
    ∇_i C, ∇_j C; ``bend_grad`` ``(b, 12)``: ∇_1..∇_4 C. Degenerate constraints get C = 0 and a zero gradient.
    """
    e = edges.shape[0]
    for c in range(e):
        i = edges[c, 0]
        j = edges[c, 1]
        d0 = x[i, 0] - x[j, 0]
        d1 = x[i, 1] - x[j, 1]
        d2 = x[i, 2] - x[j, 2]
        length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if length <= TINY_LENGTH:
            values[c] = 0.0
            stretch_grad[c, :] = 0.0
            continue
        values[c] = length - rest_length[c]
        stretch_grad[c, 0] = d0 / length
        stretch_grad[c, 1] = d1 / length
        stretch_grad[c, 2] = d2 / length
        stretch_grad[c, 3] = -d0 / length
        stretch_grad[c, 4] = -d1 / length
        stretch_grad[c, 5] = -d2 / length
    for c in range(bending.shape[0]):
        i1 = bending[c, 0]
        i2 = bending[c, 1]
        i3 = bending[c, 2]
        i4 = bending[c, 3]
        if signed_bending:
            valid, angle, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z = _bend_gradient_signed(
                x, i1, i2, i3, i4)
        else:
            valid, angle, _, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z = _bend_gradient(
                x, i1, i2, i3, i4)
        if not valid:
            values[e + c] = 0.0
            bend_grad[c, :] = 0.0
            continue
        values[e + c] = angle - rest_angle[c]
        g = bend_grad[c]
        g[0], g[1], g[2], g[3], g[4], g[5] = g1x, g1y, g1z, g2x, g2y, g2z
        g[6], g[7], g[8], g[9], g[10], g[11] = g3x, g3y, g3z, g4x, g4y, g4z


@njit(cache=True)
def tension_stiffness(x, edges, values, inverse_compliance, blocks):
    """Geometric stiffness of the stretched springs, ``blocks`` ``(e, 6, 6)`` in place: for tension
    μ = C/α > 0 along unit direction n of length l, μ/l (I − n nᵀ) on the (i, i), (j, j) blocks and its negative on
    (i, j), (j, i). Compressed springs get none, which keeps the matrix positive definite (projected Newton)."""
    for c in range(edges.shape[0]):
        i = edges[c, 0]
        j = edges[c, 1]
        d = x[i] - x[j]
        length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        tension = values[c] * inverse_compliance[c]
        blocks[c, :, :] = 0.0
        if tension <= 0.0 or length <= TINY_LENGTH:
            continue
        scale = tension / length
        for a in range(3):
            for b in range(3):
                v = scale * ((1.0 if a == b else 0.0) - d[a] * d[b] / (length * length))
                blocks[c, a, b] = v
                blocks[c, 3 + a, 3 + b] = v
                blocks[c, a, 3 + b] = -v
                blocks[c, 3 + a, b] = -v


@dataclass
class StaticReport:
    """What :meth:`LayerStatics.solve` did: Gauss–Newton ``iterations``, final ``residual`` [N] (largest free-node
    force imbalance), and ``tolerance`` [N] it was held to."""

    iterations: int
    residual: float
    tolerance: float


class LayerStatics:
    """Static equilibrium of the XPBD surface layer with some nodes prescribed (see the module docstring).

    Args:
        vertex_count: n, the surface's node count.
        edges: ``(e, 2) int`` stretch constraints (springs); rest_length: ``(e,) float64`` [m];
            stretch_compliance: ``(e,) float64`` [m/N], > 0.
        hinges: ``(b, 4) int`` bending constraints (P1, P2 | P3, P4); rest_angle: ``(b,) float64`` [rad] matching
            ``signed_bending``; bend_compliance: ``(b,) float64`` [1/(N·m)], > 0.
        prescribed: ``(k,) int`` nodes whose positions are given.
    """

    def __init__(self, vertex_count: int, *, edges, rest_length, stretch_compliance, hinges, rest_angle,
                 bend_compliance, prescribed, signed_bending: bool = False):
        self.rest_length = np.ascontiguousarray(rest_length, dtype=np.float64)
        self.rest_angle = np.ascontiguousarray(rest_angle, dtype=np.float64)
        self.signed_bending = bool(signed_bending)
        n = int(vertex_count)
        free = np.ones(n, dtype=bool)
        free[np.asarray(prescribed, dtype=np.int64)] = False
        self.free_nodes = np.flatnonzero(free)
        slot = np.full(3 * n, -1, dtype=np.int64)
        free_dofs = (3 * self.free_nodes[:, None] + np.arange(3)).ravel()
        slot[free_dofs] = np.arange(free_dofs.size)
        self._free_dofs = free_dofs
        self._weight = 1.0 / np.concatenate([stretch_compliance, bend_compliance])  # α⁻¹ per row
        edges, hinges = np.asarray(edges, dtype=np.int64), np.asarray(hinges, dtype=np.int64).reshape(-1, 4)
        cols = np.concatenate([(3 * edges[:, :, None] + np.arange(3)).reshape(-1, 6).ravel(),
                               (3 * hinges[:, :, None] + np.arange(3)).reshape(-1, 12).ravel()])
        rows = np.concatenate([np.repeat(np.arange(len(edges)), 6),
                               len(edges) + np.repeat(np.arange(len(hinges)), 12)])
        self._keep = slot[cols] >= 0
        self._rows, self._cols = rows[self._keep], slot[cols][self._keep]
        self._shape = (len(edges) + len(hinges), free_dofs.size)
        self._values = np.zeros(self._shape[0])
        self._stretch_grad = np.zeros((len(edges), 6))
        self._bend_grad = np.zeros((len(hinges), 12))
        self._edges, self._hinges = np.ascontiguousarray(edges), np.ascontiguousarray(hinges)
        edge_dofs = (3 * edges[:, :, None] + np.arange(3)).reshape(-1, 6)
        block_rows = slot[np.repeat(edge_dofs, 6, axis=1)].ravel()
        block_cols = slot[np.tile(edge_dofs, (1, 6))].ravel()
        self._block_keep = (block_rows >= 0) & (block_cols >= 0)
        self._block_rows, self._block_cols = block_rows[self._block_keep], block_cols[self._block_keep]
        self._blocks = np.zeros((len(edges), 6, 6))
        self.last: StaticReport | None = None

    def _evaluate(self, x):
        constraint_jacobian(x, self._edges, self.rest_length, self._hinges, self.rest_angle, self.signed_bending,
                            self._values, self._stretch_grad, self._bend_grad)
        data = np.concatenate([self._stretch_grad.ravel(), self._bend_grad.ravel()])[self._keep]
        jacobian = sp.csr_matrix((data, (self._rows, self._cols)), shape=self._shape)
        return self._values, jacobian

    def _energy(self, x, forces) -> float:
        values, _ = self._evaluate(x)
        return 0.5 * float(np.dot(self._weight * values, values)) - float(np.dot(forces[self.free_nodes].ravel(),
                                                                                 x[self.free_nodes].ravel()))

    def solve(self, x: np.ndarray, forces: np.ndarray, *, rtol: float = DEFAULT_RTOL) -> StaticReport:
        """Move the free nodes of ``x`` ``(n, 3)`` [m] (in place; prescribed nodes as given) to equilibrium under
        ``forces`` ``(n, 3)`` [N] (only the free nodes' forces act on the layer)."""
        from ..fem.linear import factorise_spd

        f_free = forces[self.free_nodes].ravel()
        scale = max(float(np.abs(forces).max()), 1e-300)
        tolerance = rtol * scale
        dof_node = self._free_dofs // 3
        residual = np.inf
        for iteration in range(MAX_ITERATIONS + 1):
            values, jacobian = self._evaluate(x)
            gradient = jacobian.T @ (self._weight * values) - f_free
            residual = float(np.abs(gradient).max()) if gradient.size else 0.0
            if residual <= tolerance:
                self.last = StaticReport(iteration, residual, tolerance)
                return self.last
            tension_stiffness(x, self._edges, values, self._weight, self._blocks)
            geometric = sp.csr_matrix((self._blocks.ravel()[self._block_keep], (self._block_rows, self._block_cols)),
                                      shape=(self._shape[1],) * 2)
            hessian = (jacobian.T @ sp.diags(self._weight) @ jacobian + geometric).tocsc()
            hessian = hessian + sp.identity(hessian.shape[0], format="csc") * (1e-12 * hessian.diagonal().max())
            step = -factorise_spd(hessian, dof_node).solve(gradient)
            self._line_search(x, step, gradient, forces)
        raise SolverError(
            f"the surface layer's static solve did not converge in {MAX_ITERATIONS} Gauss–Newton iterations "
            f"(force residual {residual:.3g} N > {tolerance:.3g} N); the load probably folds the surface through "
            "itself: lower the force"
        )

    def _line_search(self, x, step, gradient, forces) -> None:
        """Backtrack along ``step`` (free dofs) until Φ decreases enough (Armijo); updates ``x`` in place."""
        free = self.free_nodes
        start = x[free].copy()
        phi0 = self._energy(x, forces)
        slope = float(np.dot(gradient, step))
        t = 1.0
        for _ in range(30):
            x[free] = start + t * step.reshape(-1, 3)
            if self._energy(x, forces) <= phi0 + 1e-4 * t * slope:
                return
            t *= 0.5
        x[free] = start + t * step.reshape(-1, 3)
