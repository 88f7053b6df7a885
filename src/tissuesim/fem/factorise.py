"""Sparse Cholesky of an SPD matrix (a constrained stiffness K_ff, a layer's M/dt² + K_ff), each solve a
back-substitution.

The matrix is factorised with a nested-dissection fill-reducing ordering (METIS, via ``pymetis``) computed on the
node graph and expanded to each node's free dofs. On 3-D tet meshes minimum-degree orderings fill the factor far
more (and the flops grow faster) than nested dissection, which splits the mesh recursively along small separators.
The factor is a supernodal sparse Cholesky (CHOLMOD, from the ``cvxopt`` wheel, which links an optimised BLAS) when
cvxopt is installed, otherwise SciPy's SuperLU in symmetric mode (diagonal pivots) on the permuted matrix; without
pymetis the orderings fall back to CHOLMOD's AMD or SuperLU's minimum degree of Kᵀ+K. Measured factorisation of
~51k dofs (97k tets): SuperLU + minimum degree > 10 min, SuperLU + METIS ~31 s, CHOLMOD + METIS ~4 s (docs/fem.md).
All routes are exact to round-off.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError

__all__ = ["factorise_spd", "fill_reducing_order"]


def _nested_dissection(reduced: sp.csc_matrix, dof_node: np.ndarray):
    """METIS nested-dissection permutation of K_ff's dofs (``reduced[order][:, order]`` fills little), computed on
    the node graph (3× smaller than the dof graph, same separators) with each node's dofs kept together in
    node-major order; ``None`` when pymetis is not installed."""
    try:
        import pymetis
    except ImportError:
        return None
    _, node = np.unique(dof_node, return_inverse=True)  # free dof -> its node among the nodes with free dofs
    to_node = sp.csr_matrix((np.ones(node.size), (np.arange(node.size), node)))
    graph = (to_node.T @ (reduced != 0).astype(np.float64) @ to_node).tocsr()
    graph.setdiag(0)
    graph.eliminate_zeros()
    node_order = np.asarray(pymetis.nested_dissection(pymetis.CSRAdjacency(graph.indptr, graph.indices))[0])
    rank = np.empty(node_order.size, dtype=np.int64)
    rank[node_order] = np.arange(node_order.size)
    return np.argsort(rank[node], kind="stable")


class _Cholmod:
    """CHOLMOD supernodal LLᵀ of K_ff (cvxopt) in a given or AMD ordering; ``solve`` takes ``(f,)`` or ``(f, m)``;
    ``cholmod`` is CHOLMOD's factor object, for solves of its own systems (:mod:`.factor_update`)."""

    def __init__(self, reduced: sp.csc_matrix, order):
        from cvxopt import cholmod, matrix, spmatrix

        lower = sp.tril(reduced).tocoo()
        a = spmatrix(lower.data, matrix(lower.row.astype(np.int64)), matrix(lower.col.astype(np.int64)), lower.shape)
        del lower  # the factor needs the memory (a quadratic reference level: ~1 GB here)
        if order is None:
            self.cholmod = cholmod.symbolic(a, uplo="L")
        else:  # CHOLMOD factorises A(p, p) and permutes in its solve
            self.cholmod = cholmod.symbolic(a, p=matrix(order.astype(np.int64)), uplo="L")
        try:
            cholmod.numeric(a, self.cholmod)
        except ArithmeticError:  # a non-positive (or zero) pivot: K_ff is not positive definite
            raise SolverError(
                "the constrained stiffness matrix is not positive definite (Cholesky failed); "
                "check the mesh for inverted or degenerate tets"
            ) from None
        self._solve, self._matrix = cholmod.solve, matrix
        self.order = order

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        x = self._matrix(np.ascontiguousarray(rhs, dtype=np.float64))
        self._solve(self.cholmod, x)
        return np.array(x).reshape(rhs.shape)

    def workspace(self, size: int):
        """``(buffer, view)``: a right-hand side for :meth:`solve_in_place` and a NumPy view of it ``(size,)``."""
        buffer = self._matrix(0.0, (size, 1))
        return buffer, np.asarray(buffer).reshape(size)

    def solve_in_place(self, buffer) -> None:
        """Overwrite a :meth:`workspace` buffer holding b with the solution x of K x = b (allocates nothing)."""
        self._solve(self.cholmod, buffer)


class _PermutedLU:
    """SuperLU of ``K_ff[order][:, order]``; ``solve`` undoes the permutation."""

    def __init__(self, lu, order):
        self._lu, self._order = lu, order

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        x = np.empty_like(rhs, dtype=np.float64)
        x[self._order] = self._lu.solve(rhs[self._order])
        return x


def fill_reducing_order(reduced: sp.csc_matrix, dof_node: np.ndarray) -> np.ndarray | None:
    """The METIS nested-dissection order of ``reduced``'s dofs that :func:`factorise_spd` uses (None without
    pymetis): compute it once for a sequence of matrices with one sparsity pattern (Newton's tangents)."""
    return _nested_dissection(reduced, dof_node)


def factorise_spd(reduced: sp.csc_matrix, dof_node: np.ndarray, *,
                  order: np.ndarray | None = None) -> _Cholmod | _PermutedLU | spla.SuperLU:
    """Factorise the SPD K_ff once (see the module docstring); ``dof_node`` ``(f,)`` is the node of each free dof;
    ``order`` a :func:`fill_reducing_order` of the same pattern, computed here when not given.

    Returns an object whose ``solve(b)`` takes ``(f,)`` or ``(f, m)``. Raises SolverError if K_ff is not positive
    definite."""
    if order is None:
        order = _nested_dissection(reduced, dof_node)
    try:
        import cvxopt  # noqa: F401  (optional: CHOLMOD)
    except ImportError:
        pass
    else:
        return _Cholmod(reduced, order)
    if order is None:
        return _superlu(reduced, "MMD_AT_PLUS_A")
    return _PermutedLU(_superlu(reduced[order][:, order].tocsc(), "NATURAL"), order)


def _superlu(reduced: sp.csc_matrix, permc_spec: str):
    """SuperLU with symmetric ordering and diagonal pivots (positive-definiteness checked from the pivots)."""
    try:
        lu = spla.splu(reduced, permc_spec=permc_spec, diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError as error:  # SuperLU reports an exactly singular factor this way
        raise SolverError(f"the constrained stiffness matrix is singular ({error}); check the mesh and supports") from None
    # With symmetric permutations and diagonal pivots U's diagonal holds the pivots of an LDLᵀ, whose signs equal
    # K_ff's eigenvalue signs (Sylvester's law of inertia): all positive iff K_ff is positive definite.
    pivots = lu.U.diagonal()
    if not np.all(pivots > 0):
        bad = np.flatnonzero(~(pivots > 0))
        raise SolverError(
            f"the constrained stiffness matrix is not positive definite ({bad.size} non-positive pivots); "
            "check the mesh for inverted or degenerate tets"
        )
    return lu
