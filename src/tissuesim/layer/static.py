"""The surface layer's static equilibrium in small strain: one sparse solve with the layer's stiffness at rest.

The XPBD form's constraints define an elastic energy (Macklin et al. 2016, U = Σ_c C_c²/(2 α_c)): stretch (eq 8)
and bending (eq 10, the signed angle) with the material's compliance α (:mod:`tissuesim.layer.compliance`).
Linearised at rest, C ≈ J u with J the constraint Jacobian at the rest positions, so U ≈ ½ uᵀ K u with the layer's
stiffness K = Jᵀ α⁻¹ J. With the prescribed nodes' displacements u_p given (control nodes at their FEM
displacement, fixed nodes at zero) and nodal forces f on the free nodes, the equilibrium is

    K_ff u_f = f_f − K_fp u_p.

This is the same small-strain (linear) elasticity as the FEM on M_V that drives the control nodes and the fine FEM
it is compared with: the hybrid's quasi-static answer is then exactly linear in the load and in 1/E, and depends on
nothing else (not dt, node masses, density or a sweep count, which shape only the path of a time-stepped solve).
K_ff is factorised once per solver; each load costs one back-substitution.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit
from numpy.typing import ArrayLike

from ..errors import SolverError
from ..fem.factorise import factorise_spd
from .hinge_kernels import TINY_LENGTH, bend_gradient, bend_gradient_signed


@njit(cache=True)
def constraint_jacobian(x: np.ndarray, edges: np.ndarray, bending: np.ndarray, signed_bending: bool,
                        stretch_grad: np.ndarray, bend_grad: np.ndarray) -> None:
    """Constraint gradients at positions ``x`` ``(n, 3)`` [m], in place: ``stretch_grad`` ``(e, 6)`` holds ∇_i C,
    ∇_j C of each stretch constraint; ``bend_grad`` ``(b, 12)`` ∇_1..∇_4 C of each hinge. Degenerate constraints get
    a zero gradient."""
    for c in range(edges.shape[0]):
        i = edges[c, 0]
        j = edges[c, 1]
        d0 = x[i, 0] - x[j, 0]
        d1 = x[i, 1] - x[j, 1]
        d2 = x[i, 2] - x[j, 2]
        length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        stretch_grad[c, :] = 0.0
        if length <= TINY_LENGTH:
            continue
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
            valid, _, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z = bend_gradient_signed(
                x, i1, i2, i3, i4)
        else:
            valid, _, _, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z, g4x, g4y, g4z = bend_gradient(
                x, i1, i2, i3, i4)
        g = bend_grad[c]
        g[:] = 0.0
        if not valid:
            continue
        g[0], g[1], g[2], g[3], g[4], g[5] = g1x, g1y, g1z, g2x, g2y, g2z
        g[6], g[7], g[8], g[9], g[10], g[11] = g3x, g3y, g3z, g4x, g4y, g4z


def layer_stiffness(rest_positions: ArrayLike, *, edges: ArrayLike, stretch_compliance: ArrayLike, hinges: ArrayLike,
                    bend_compliance: ArrayLike, signed_bending: bool = True) -> sp.csr_matrix:
    """``(3n, 3n)`` CSR stiffness K = Jᵀ α⁻¹ J [N/m] of the layer linearised at ``rest_positions`` ``(n, 3)`` [m].

    ``edges`` ``(e, 2) int``, ``stretch_compliance`` ``(e,)`` [m/N]; ``hinges`` ``(b, 4) int``, ``bend_compliance``
    ``(b,)`` [1/(N·m)]. Symmetric positive semi-definite (rigid motions are its null space).
    """
    x = np.ascontiguousarray(rest_positions, dtype=np.float64)
    edges = np.ascontiguousarray(edges, dtype=np.int64).reshape(-1, 2)
    hinges = np.ascontiguousarray(hinges, dtype=np.int64).reshape(-1, 4)
    stretch_grad, bend_grad = np.zeros((len(edges), 6)), np.zeros((len(hinges), 12))
    constraint_jacobian(x, edges, hinges, bool(signed_bending), stretch_grad, bend_grad)
    cols = np.concatenate([(3 * edges[:, :, None] + np.arange(3)).reshape(-1), (3 * hinges[:, :, None]
                                                                               + np.arange(3)).reshape(-1)])
    rows = np.concatenate([np.repeat(np.arange(len(edges)), 6), len(edges) + np.repeat(np.arange(len(hinges)), 12)])
    jacobian = sp.csr_matrix((np.concatenate([stretch_grad.ravel(), bend_grad.ravel()]), (rows, cols)),
                             shape=(len(edges) + len(hinges), 3 * len(x)))
    inverse_compliance = sp.diags(1.0 / np.concatenate([stretch_compliance, bend_compliance]))
    return (jacobian.T @ inverse_compliance @ jacobian).tocsr()


@njit(cache=True)
def implicit_rhs(positions: np.ndarray, velocities: np.ndarray, rest: np.ndarray, free: np.ndarray,
                 inertia: np.ndarray, keep: float, dt: float, forces: np.ndarray, indptr: np.ndarray,
                 indices: np.ndarray, data: np.ndarray, prescribed: np.ndarray, targets: np.ndarray,
                 out: np.ndarray) -> None:
    """``out`` ``(3f,)`` = M/dt² (u_f + dt (1 − damping) v_f) + f_f − K_fp u_p, in place (``keep`` = 1 − damping;
    K_fp as CSR ``indptr, indices, data`` over the prescribed dofs; u_p = targets − rest of the prescribed nodes)."""
    for r in range(free.shape[0]):
        i = free[r]
        for k in range(3):
            row = 3 * r + k
            coupled = 0.0
            for q in range(indptr[row], indptr[row + 1]):
                col = indices[q]
                node = col // 3
                coupled += data[q] * (targets[node, col % 3] - rest[prescribed[node], col % 3])
            u = positions[i, k] - rest[i, k]
            out[row] = inertia[row] * (u + dt * keep * velocities[i, k]) + forces[i, k] - coupled


@njit(cache=True)
def implicit_update(solution: np.ndarray, positions: np.ndarray, velocities: np.ndarray, rest: np.ndarray,
                    free: np.ndarray, prescribed: np.ndarray, targets: np.ndarray, dt: float) -> None:
    """New positions (free: rest + ``solution`` ``(3f,)``; prescribed: ``targets``) and v = Δx/dt, in place."""
    inv_dt = 1.0 / dt
    for r in range(free.shape[0]):
        i = free[r]
        for k in range(3):
            x = rest[i, k] + solution[3 * r + k]
            velocities[i, k] = (x - positions[i, k]) * inv_dt
            positions[i, k] = x
    for r in range(prescribed.shape[0]):
        i = prescribed[r]
        for k in range(3):
            velocities[i, k] = (targets[r, k] - positions[i, k]) * inv_dt
            positions[i, k] = targets[r, k]


class LayerStatics:
    """Small-strain static equilibrium of a surface layer with some nodes prescribed (module docstring).

    Args:
        stiffness: ``(3n, 3n)`` layer stiffness [N/m] (:func:`layer_stiffness`).
        prescribed: ``(k,) int`` nodes whose displacements are given.

    :meth:`displacement` raises SolverError if the free part K_ff is singular (a free node the layer does not hold
    in some direction, as a cut can leave); :meth:`implicit_step` never needs K_ff alone.

    Attributes:
        free_stiffness: ``(3f, 3f)`` CSC K_ff [N/m] of the free nodes' dofs; ``dof_node`` ``(3f,) int64`` the node
            of each.
        dynamic: ``(dt [s], factor, inertia, buffer, rhs)`` of the last :meth:`implicit_step`'s dt
            (:meth:`dynamic_factor`), or None before the first.
        cut_base: what the first cut of this layer starts from, built ahead in the background
            (:func:`~tissuesim.layer.cut_statics.prepare`), or None.
    """

    def __init__(self, stiffness: sp.csr_matrix, *, prescribed: ArrayLike):
        n = stiffness.shape[0] // 3
        free = np.ones(n, dtype=bool)
        free[np.asarray(prescribed, dtype=np.int64)] = False
        self.free_nodes = np.flatnonzero(free)
        self.prescribed = np.asarray(prescribed, dtype=np.int64)
        free_dofs = (3 * self.free_nodes[:, None] + np.arange(3)).ravel()
        fixed_dofs = (3 * self.prescribed[:, None] + np.arange(3)).ravel()
        stiffness = stiffness.tocsr()
        self.stiffness = stiffness
        self._coupling = stiffness[free_dofs][:, fixed_dofs].tocsr()
        self.free_stiffness = stiffness[free_dofs][:, free_dofs].tocsc()
        self.dof_node = free_dofs // 3
        self._factor = None  # K_ff's, on the first static solve (a cut can leave it singular; M/dt² + K_ff is not)
        self.dynamic: tuple[float, object] | None = None
        self.cut_base = None

    def implicit_step(self, positions: np.ndarray, velocities: np.ndarray, rest: np.ndarray, forces: np.ndarray,
                      targets: np.ndarray, mass: np.ndarray, dt: float, damping: float) -> None:
        """One implicit-Euler step of the linear layer, in place on ``positions``, ``velocities`` ``(n, 3)``.

        Solves (M/dt² + K_ff) u' = M/dt² (u + dt (1 − damping) v) + f_f − K_fp u_p for the free nodes (u = x − rest,
        ``forces`` ``(n, 3)`` [N], lumped ``mass`` ``(n,)`` [kg], prescribed nodes at ``targets`` ``(k, 3)`` [m], in
        the order of :attr:`prescribed` as given); v = Δx/dt. Its fixed point (x' = x, v = 0) is :meth:`displacement`'s
        equilibrium, for any dt and mass. The matrix is factorised once per dt; with CHOLMOD a step allocates
        nothing."""
        if self.free_nodes.size == 0:  # every node prescribed (e.g. a near field over the whole surface)
            implicit_update(np.zeros(0), positions, velocities, rest, self.free_nodes, self.prescribed, targets, dt)
            return
        if self.dynamic is None or self.dynamic[0] != dt:
            self.dynamic = (dt, *self.dynamic_factor(mass, dt))
        _, factor, inertia, buffer, rhs = self.dynamic
        coupling = self._coupling
        implicit_rhs(positions, velocities, rest, self.free_nodes, inertia, 1.0 - damping, dt, forces,
                     coupling.indptr, coupling.indices, coupling.data, self.prescribed, targets, rhs)
        if buffer is None:
            solution = np.asarray(factor.solve(rhs))
        else:
            factor.solve_in_place(buffer)
            solution = rhs
        implicit_update(solution, positions, velocities, rest, self.free_nodes, self.prescribed, targets, dt)

    def dynamic_factor(self, mass: np.ndarray, dt: float) -> tuple[object, np.ndarray, object, np.ndarray]:
        """``(factor, inertia (3f,) [N/m], buffer, rhs (3f,))``: the factor of M/dt² + K_ff for the lumped ``mass``
        ``(n,)`` [kg] and step ``dt`` [s], the inertia M/dt² of the free dofs, and the right-hand side's workspace (a
        CHOLMOD buffer and its NumPy view; None and an array without CHOLMOD)."""
        inertia = np.repeat(mass[self.free_nodes], 3) / (dt * dt)
        factor = factorise_spd((self.free_stiffness + sp.diags(inertia)).tocsc(), self.dof_node)
        if hasattr(factor, "workspace"):
            buffer, rhs = factor.workspace(inertia.size)
        else:
            buffer, rhs = None, np.zeros(inertia.size)
        return factor, inertia, buffer, rhs

    def displacement(self, forces: np.ndarray, prescribed_displacement: np.ndarray) -> np.ndarray:
        """``(f, 3) float64`` displacements [m] of the free nodes (in :attr:`free_nodes` order) under nodal
        ``forces`` ``(n, 3)`` [N], the prescribed nodes moved by ``prescribed_displacement`` ``(k, 3)`` [m]."""
        if self.free_nodes.size == 0:
            return np.zeros((0, 3))
        rhs = forces[self.free_nodes].ravel() - self._coupling @ np.ravel(prescribed_displacement)
        return np.asarray(self._free_factor().solve(rhs)).reshape(-1, 3)

    def displacement_columns(self, forces: np.ndarray, prescribed_displacement: np.ndarray) -> np.ndarray:
        """``(3f, m) float64`` the free nodes' displacements [m] (node-major, :attr:`free_nodes` order) in ``m``
        load cases at once: free-node forces ``(3f, m)`` [N] and prescribed displacements ``(3k, m)`` [m] (node-major,
        :attr:`prescribed` order); one call of K_ff's factor."""
        rhs = forces - self._coupling @ prescribed_displacement
        return np.asarray(self._free_factor().solve(np.ascontiguousarray(rhs))).reshape(rhs.shape)

    def _free_factor(self):
        """K_ff's factor, made on first use."""
        if self._factor is None:
            try:
                self._factor = factorise_spd(self.free_stiffness, self.dof_node)
            except SolverError as error:
                raise SolverError(f"the surface layer does not hold every free node ({error}); a cut may have left "
                                  "a flap that only its inertia holds") from None
        return self._factor
