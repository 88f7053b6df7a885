"""Exact solves with a matrix that differs from an already factorised one on a few dofs: the stale factor and a
low-rank (Woodbury) correction, so that a local change, such as a cut, costs no refactorisation.

The base matrix A₀ (n₀ × n₀, SPD) is factorised once as P A₀ Pᵀ = L Lᵀ (CHOLMOD). The current matrix A has the
base's dofs first and e extra ones after them, and A − B is zero outside a set P of "modified" dofs, where

    B = [[A₀, 0], [0, diag(d)]]        (d > 0 on the extra dofs: the current diagonal there)

With B = R Rᵀ, R = [[Pᵀ L, 0], [0, diag(√d)]], U the columns of the identity at P, S = (A − B)_PP and
G = R⁻¹ U, the push-through form of the Woodbury identity (valid for an indefinite S) gives

    A⁻¹ b = R⁻ᵀ (w − G S (I + GᵀG S)⁻¹ Gᵀ w),    w = R⁻¹ b.

A solve is then one forward and one backward substitution with the stale factor (one ordinary solve) plus dense
work on |P| columns. A column of G for a base dof is L⁻¹ P eₚ, which is nonzero only on the path from that dof to
the root of the elimination tree: :class:`ExplicitFactor` keeps L explicitly and solves for such sparse
right-hand sides touching only those columns (Gilbert & Peierls 1988), so a local change costs a few hundred
sparse columns, not a factorisation. Everything is exact to round-off.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numba import njit

from ..errors import SolverError
from .factorise import factorise_spd

if TYPE_CHECKING:
    from .factorise import _Cholmod

__all__ = ["CorrectedSolve", "ExplicitFactor", "SparseColumns"]


@njit(cache=True)
def _etree_path_solve(indptr, indices, data, parent, start, x, mark, stack):
    """Solve L y = e_start in place into ``x`` (all zero on entry) touching only the path from ``start`` to the
    root of the elimination tree; returns the path (sorted), where ``y`` may be nonzero."""
    top = 0
    j = start
    while j != -1 and mark[j] == 0:
        mark[j] = 1
        stack[top] = j
        top += 1
        j = parent[j]
    path = np.sort(stack[:top])
    x[start] = 1.0
    for c in path:
        a = indptr[c]
        xc = x[c] / data[a]
        x[c] = xc
        for q in range(a + 1, indptr[c + 1]):
            x[indices[q]] -= data[q] * xc
    for c in path:
        mark[c] = 0
    return path


class ExplicitFactor:
    """The Cholesky factor of an SPD ``matrix`` ``(n₀, n₀)`` held twice: CHOLMOD's supernodal factor for dense
    solves, and its L as CSC arrays for right-hand sides with one nonzero (:meth:`unit_column`).

    Args:
        matrix: the SPD matrix (CSC). dof_node: ``(n₀,)`` the node of each dof (the fill-reducing order's graph).
        factor: its CHOLMOD factor from :func:`~.factorise.factorise_spd`, if there is one already.
    """

    def __init__(self, matrix: sp.csc_matrix, dof_node: np.ndarray, *, factor: _Cholmod | None = None):
        from cvxopt import cholmod, matrix as dense

        self.size = matrix.shape[0]
        self.factor = factor if factor is not None else factorise_spd(matrix, dof_node)
        if not hasattr(self.factor, "workspace"):
            raise SolverError("an updated factor needs CHOLMOD (pip install cvxopt)")
        self._cholmod, self._dense = cholmod, dense
        # CHOLMOD's getfactor turns the factor it reads into a symbolic one: L is read from a second factorisation
        # in the same order (so the same permutation)
        explicit = factorise_spd(matrix, dof_node, order=self.factor.order).cholmod
        positions = dense(np.arange(self.size, dtype=np.float64).reshape(-1, 1))
        cholmod.solve(explicit, positions, sys=7)
        #: ``(n₀,) int64``: the dof at each position of the factor's order
        self.order = np.asarray(positions).ravel().astype(np.int64)
        lower = cholmod.getfactor(explicit)
        l_csc = sp.csc_matrix((np.asarray(lower.V).ravel(), (np.asarray(lower.I).ravel(),
                                                             np.asarray(lower.J).ravel())), shape=matrix.shape)
        l_csc.sort_indices()
        self._indptr, self._indices = l_csc.indptr.astype(np.int64), l_csc.indices.astype(np.int64)
        self._data = l_csc.data
        below = np.diff(self._indptr) > 1
        self._parent = np.full(self.size, -1, dtype=np.int64)
        self._parent[below] = self._indices[self._indptr[:-1][below] + 1]   # first entry below the diagonal
        self._position = np.empty(self.size, dtype=np.int64)
        self._position[self.order] = np.arange(self.size)
        self._work = (np.zeros(self.size), np.zeros(self.size, dtype=np.int64), np.zeros(self.size, dtype=np.int64))

    def unit_column(self, dof: int) -> tuple[np.ndarray, np.ndarray]:
        """``(rows, values)``: the nonzeros of L⁻¹ P e_dof (rows in the factor's order)."""
        x, mark, stack = self._work
        path = _etree_path_solve(self._indptr, self._indices, self._data, self._parent,
                                 self._position[int(dof)], x, mark, stack)
        values = x[path].copy()
        x[path] = 0.0
        return path, values

    def forward(self, b: np.ndarray) -> np.ndarray:
        """``(n₀,)`` L⁻¹ P b (in the factor's order)."""
        w = self._dense(np.ascontiguousarray(b[self.order], dtype=np.float64).reshape(-1, 1))
        self._cholmod.solve(self.factor.cholmod, w, sys=4)
        return np.asarray(w).ravel()

    def backward(self, w: np.ndarray) -> np.ndarray:
        """``(n₀,)`` Pᵀ L⁻ᵀ w (back in the matrix's order)."""
        x = self._dense(np.ascontiguousarray(w, dtype=np.float64).reshape(-1, 1))
        self._cholmod.solve(self.factor.cholmod, x, sys=5)
        out = np.empty(self.size)
        out[self.order] = np.asarray(x).ravel()
        return out


class SparseColumns:
    """G = L⁻¹ P [e_d ...] for a growing set of base dofs d, held dense on the union of their elimination-tree
    paths, with its Gram matrix GᵀG: a new dof costs its own path and its Gram row, not the others' again."""

    def __init__(self, base: ExplicitFactor):
        self.base = base
        self._index: dict[int, int] = {}
        self.rows = np.zeros(0, dtype=np.int64)
        self._g, self._gram = np.zeros((0, 0)), np.zeros((0, 0))

    def arranged(self, dofs: np.ndarray) -> np.ndarray:
        """``dofs`` ``(k,)`` reordered as they are (or will be) held: those held first, in their order, then the
        others. :meth:`take` of arranged dofs that are all the held ones copies nothing."""
        dofs = np.asarray(dofs, dtype=np.int64)
        held = np.array([self._index.get(d, -1) for d in dofs.tolist()], dtype=np.int64)
        known = held >= 0
        return np.concatenate([dofs[known][np.argsort(held[known], kind="stable")], dofs[~known]])

    def take(self, dofs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(rows, g, gram)`` of base ``dofs`` ``(k,)``: the path rows (the factor's order), G's columns there
        ``(r, k)`` and GᵀG ``(k, k)`` (views of the held arrays where ``dofs`` are all of them, in order)."""
        dofs = np.asarray(dofs, dtype=np.int64).tolist()
        new = [d for d in dict.fromkeys(dofs) if d not in self._index]
        if new:
            self._add(new)
        at = np.array([self._index[d] for d in dofs], dtype=np.int64)
        if at.size == self._g.shape[1] and np.array_equal(at, np.arange(at.size)):
            return self.rows, self._g, self._gram
        return self.rows, self._g[:, at], self._gram[np.ix_(at, at)]

    def _add(self, dofs: list) -> None:
        paths = [self.base.unit_column(d) for d in dofs]
        rows = np.union1d(self.rows, np.concatenate([path for path, _ in paths]))
        old = self._g.shape[1]
        g = np.zeros((rows.size, old + len(dofs)))
        g[np.searchsorted(rows, self.rows), :old] = self._g
        for k, (path, values) in enumerate(paths):
            g[np.searchsorted(rows, path), old + k] = values
        cross = g.T @ g[:, old:]
        gram = np.empty((g.shape[1], g.shape[1]))
        gram[:old, :old] = self._gram
        gram[:, old:] = cross
        gram[old:, :old] = cross[:old].T
        self.rows, self._g, self._gram = rows, g, gram
        self._index.update((d, old + k) for k, d in enumerate(dofs))


class CorrectedSolve:
    """Exact solves with A, given the base's :class:`ExplicitFactor` (module docstring).

    Args:
        columns: the base's :class:`SparseColumns` (they depend on the base alone, so every correction of one
            base shares them).
        modified: ``(p,) int64`` the dofs P of A where A − B may be nonzero, every extra dof among them.
        difference: ``(p, p)`` S = (A − B)_PP (symmetric; sparse or dense).
        extra_diagonal: ``(e,) float64`` d > 0, B's diagonal on the extra dofs.
    """

    def __init__(self, columns: SparseColumns, *, modified: np.ndarray, difference: np.ndarray,
                 extra_diagonal: np.ndarray):
        base = columns.base
        n0 = base.size
        self.base, self.size = base, n0 + extra_diagonal.size
        self._scale = np.sqrt(extra_diagonal)
        modified = np.asarray(modified, dtype=np.int64)
        in_base = modified < n0
        self._base_slots, self._extra_slots = np.flatnonzero(in_base), np.flatnonzero(~in_base)
        self._extra_dofs = modified[~in_base] - n0
        self._rows, self._g, base_gram = columns.take(modified[in_base])
        gram = np.zeros((modified.size, modified.size))
        gram[np.ix_(self._base_slots, self._base_slots)] = base_gram
        gram[self._extra_slots, self._extra_slots] = 1.0 / extra_diagonal[self._extra_dofs]
        self._difference = sp.csr_matrix(difference)
        capacitance = np.eye(modified.size) + (self._difference.T @ gram.T).T      # I + GᵀG S, S sparse
        try:
            self._capacitance = la.lu_factor(capacitance, check_finite=True)
        except (ValueError, la.LinAlgError) as error:
            raise SolverError(f"the corrected matrix is singular ({error})") from None

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``(n,)`` A⁻¹ b."""
        n0 = self.base.size
        w = self.base.forward(b[:n0])
        w_extra = b[n0:] / self._scale
        t = np.empty(self._difference.shape[0])
        t[self._base_slots] = self._g.T @ w[self._rows]
        t[self._extra_slots] = w_extra[self._extra_dofs] / self._scale[self._extra_dofs]
        z = self._difference @ la.lu_solve(self._capacitance, t)
        w[self._rows] -= self._g @ z[self._base_slots]
        w_extra[self._extra_dofs] -= z[self._extra_slots] / self._scale[self._extra_dofs]
        return np.concatenate([self.base.backward(w), w_extra / self._scale])
