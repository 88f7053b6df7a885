"""The linear layer's implicit step after cuts, on the factor of the layer before them: no refactorisation per move.

A cutting move changes the layer's implicit matrix M/dt² + K_ff on a few dofs: the constraints it retires and
makes, the lumped masses it moves, the vertices it adds and the control nodes it releases (now free). The step
solves with the factor made before the first of a series of cuts and an exact low-rank correction
(:mod:`tissuesim.fem.factor_update`), so the step after a move costs one ordinary solve plus work on the dofs the
cuts touched. The answer equals a freshly built layer's to round-off. Once the cuts have touched more than
:data:`MAX_MODIFIED` dofs (the correction's dense work grows as their square), or when dt changes, the layer is
factorised again as it stands (its explicit factor for the next cuts built in the background).
"""

from __future__ import annotations

import threading

import numpy as np
import scipy.sparse as sp

from .static import LayerStatics

#: Modified dofs a corrected layer carries before it is factorised again.
MAX_MODIFIED = 900
#: Modified dofs past which the next base (the layer as it stands, factorised) is built in the background while the
#: current one carries on; the series moves over to it as soon as it is ready, so most series never reach
#: :data:`MAX_MODIFIED` and never wait for a factorisation.
RENEW_MODIFIED = 450


class _Base:
    """What every corrected layer of one series of cuts shares: the layer before the cuts and its explicit factor."""

    def __init__(self, statics: LayerStatics):
        from ..fem.factor_update import ExplicitFactor, SparseColumns

        dt, factor, inertia, _, _ = statics.dynamic
        self.dt, self.inertia = dt, inertia
        self.stiffness = statics.stiffness
        self.free_nodes = statics.free_nodes
        self.prescribed = statics.prescribed
        self.factor = ExplicitFactor((statics.free_stiffness + sp.diags(inertia)).tocsc(), statics.dof_node,
                                     factor=factor)
        self.mass = inertia[::3] * dt * dt       # the free nodes' masses at the base [kg]
        self.columns = SparseColumns(self.factor)
        # K_fp of the base, and the dof of each of its columns: kept for the columns still prescribed after a cut
        self._coupling, self._coupling_dofs = statics._coupling.tocsr(), _dofs(statics.prescribed)
        self._remapped = (statics.prescribed.tobytes(), self._coupling)
        #: the next base being built, from a corrected layer of this series (:data:`RENEW_MODIFIED`), or None
        self.successor: _Successor | None = None

    def coupling(self, prescribed: np.ndarray, n: int) -> sp.csr_matrix:
        """The base's K_fp with its columns in the order of ``prescribed`` ``(k,)`` (a column no longer prescribed
        dropped; n vertices now), kept while the prescribed nodes stay the same (most moves)."""
        key, remapped = self._remapped
        if key != prescribed.tobytes():
            column = np.full(3 * n, -1, dtype=np.int64)
            column[_dofs(prescribed)] = np.arange(3 * prescribed.size)
            coo = self._coupling.tocoo()
            columns = column[self._coupling_dofs[coo.col]]
            keep = columns >= 0
            remapped = sp.csr_matrix((coo.data[keep], (coo.row[keep], columns[keep])),
                                     shape=(coo.shape[0], 3 * prescribed.size))
            self._remapped = (prescribed.tobytes(), remapped)
        return remapped


class _Pending:
    """A :class:`_Base` being built on a thread of its own, so that the press of a scalpel does not wait for it.
    cvxopt's CHOLMOD holds the interpreter lock while it factorises (measured: the main thread's longest pause
    94 ms at 10k), so this moves the work off the cutting move, not out of the process's time."""

    def __init__(self, build):
        self._result = self._error = None
        self._thread = threading.Thread(target=self._build, args=(build,), daemon=True)
        self._thread.start()

    def _build(self, build) -> None:
        try:
            self._result = build()
        except Exception as error:     # handed to the caller of result()
            self._error = error

    @property
    def ready(self) -> bool:
        return not self._thread.is_alive()

    def result(self) -> _Base | None:
        """The base, or None where it cannot be built (then the layer is refactorised after each cut)."""
        self._thread.join()
        return None if self._error is not None else self._result


def prepare(statics: LayerStatics) -> None:
    """Start building, in the background, what the first cut of a layer ``statics`` needs (its explicit factor:
    a second factorisation), so that the first move does not wait for it. Nothing to prepare for a layer not
    stepped yet, or factorised without CHOLMOD (then each cut refactorises the layer, as without this module)."""
    if (type(statics) is LayerStatics and statics.dynamic is not None and hasattr(statics.dynamic[1], "workspace")
            and statics.cut_base is None):
        statics.cut_base = _Pending(lambda: _Base(statics))


class _Successor(_Pending):
    """The next base of a series, built in the background from the corrected layer ``corrected`` as it stands
    (its stiffness, prescribed nodes, the lumped ``mass`` (n,) [kg] and ``dt`` [s], all copied now)."""

    def __init__(self, corrected, mass: np.ndarray, dt: float):
        self.change, self.vertex_count = corrected.change, corrected.change.shape[0] // 3
        prescribed, mass = corrected.prescribed.copy(), mass.copy()
        super().__init__(lambda: _Base(_factorised(LayerStatics(corrected.stiffness, prescribed=prescribed), mass,
                                                   dt, explicit=False)))

    def rebased(self, total: sp.csr_matrix, mass: np.ndarray, prescribed: np.ndarray):
        """The layer with ``total`` change since the old base, corrected from this new base (waiting for it);
        None where it does not apply (a move taken back since, a node it had free is prescribed)."""
        base = self.result()
        n = total.shape[0] // 3
        if base is None or self.vertex_count > n or np.isin(base.free_nodes, prescribed).any():
            return None
        since = (total - _padded(self.change, 3 * n)).tocsr()
        corrected = CutLayerStatics(base, change=since, mass=mass, prescribed=prescribed)
        return corrected if corrected.modified_count <= MAX_MODIFIED else None


def after_cut(statics: LayerStatics, *, change: sp.csr_matrix, mass: np.ndarray,
              prescribed: np.ndarray) -> LayerStatics | None:
    """The layer after a cut: ``statics`` (before it) corrected by ``change`` ``(3n, 3n)`` [N/m] (the stiffness the
    cut added minus what it removed, n the vertices after it), the lumped ``mass`` ``(n,)`` [kg] and the
    ``prescribed`` nodes after it. Past :data:`MAX_MODIFIED` touched dofs the layer is factorised again here, its
    explicit factor for the next cuts built in the background. None where nothing of the layer can be reused (no
    step taken yet, no CHOLMOD, a node that was free is prescribed now): it is then built when next needed."""
    prescribed = np.asarray(prescribed, dtype=np.int64)
    if isinstance(statics, CutLayerStatics):
        if statics.refactorised is not None:     # dt changed since the base: go on from the layer factorised anew
            return after_cut(statics.refactorised, change=change, mass=mass, prescribed=prescribed)
        base, total = statics.base, _padded(statics.change, change.shape[0]) + change
    elif type(statics) is LayerStatics and statics.dynamic is not None:
        prepare(statics)
        pending = statics.cut_base
        base, total = (None if pending is None else pending.result()), change
    else:
        return None
    if base is None or np.isin(base.free_nodes, prescribed).any():
        return None
    total = total.tocsr()
    corrected = CutLayerStatics(base, change=total, mass=mass, prescribed=prescribed)
    successor = base.successor
    if successor is not None and (successor.ready or corrected.modified_count > MAX_MODIFIED):
        rebased = successor.rebased(total, mass, prescribed)
        if rebased is not None:
            return rebased
        base.successor = None
    if corrected.modified_count > MAX_MODIFIED:
        return _factorised(LayerStatics(corrected.stiffness, prescribed=prescribed), mass, base.dt)
    if corrected.modified_count > RENEW_MODIFIED and base.successor is None:
        base.successor = _Successor(corrected, mass, base.dt)
    return corrected


def _factorised(statics: LayerStatics, mass: np.ndarray, dt: float, *, explicit: bool = True) -> LayerStatics:
    """``statics`` with its implicit step's factor for ``dt`` made now, and (``explicit``) its explicit factor
    started in the background."""
    statics.dynamic = (dt, *statics.dynamic_factor(mass, dt))
    if explicit:
        prepare(statics)
    return statics


class CutLayerStatics(LayerStatics):
    """A layer after cuts (module docstring); :attr:`free_nodes` are the base's, then the ones the cuts freed."""

    def __init__(self, base: _Base, *, change: sp.csr_matrix, mass: np.ndarray, prescribed: np.ndarray):
        from ..fem.factor_update import CorrectedSolve

        n = change.shape[0] // 3
        self.base, self.change, self.prescribed = base, change, prescribed
        original = _padded(base.stiffness, 3 * n)
        free = np.ones(n, dtype=bool)
        free[prescribed] = False
        free[base.free_nodes] = False
        extra = np.flatnonzero(free)
        self.free_nodes = np.concatenate([base.free_nodes, extra])
        dofs = _dofs(self.free_nodes)
        self._inertia = np.repeat(mass[self.free_nodes], 3) / base.dt ** 2
        self._coupling = _padded_rows(base.coupling(prescribed, n), dofs.size)
        self._coupling_change = self._coupling_change_of(n, extra, dofs)
        #: the layer factorised anew for a new dt (:meth:`implicit_step`), which the next cut goes on from
        self.refactorised: LayerStatics | None = None
        n0 = base.inertia.size
        modified = self._modified(n, extra, mass)
        in_base = modified < n0
        modified = np.concatenate([base.columns.arranged(modified[in_base]), modified[~in_base]])
        in_base = modified < n0
        self.modified_count = modified.size
        if self.modified_count > MAX_MODIFIED:
            return
        at = dofs[modified]
        unchanged = original[at][:, at].toarray()
        difference = unchanged + change[at][:, at].toarray() + np.diag(self._inertia[modified])
        difference[np.ix_(in_base, in_base)] -= (unchanged[np.ix_(in_base, in_base)]
                                                  + np.diag(base.inertia[modified[in_base]]))
        extra = dofs[n0:]
        extra_diagonal = _diagonal(original, extra) + _diagonal(change, extra) + self._inertia[n0:]
        difference[~in_base, ~in_base] -= extra_diagonal[modified[~in_base] - n0]
        self._solver = CorrectedSolve(base.columns, modified=modified, difference=difference,
                                      extra_diagonal=extra_diagonal)

    def _coupling_change_of(self, n: int, extra: np.ndarray, dofs: np.ndarray) -> sp.csr_matrix:
        """What K_fp has beyond the base's (rows: the current free dofs; columns: the prescribed ones in order): the
        freed nodes' rows of the base stiffness and the cuts' change. Small: a step applies it on its own."""
        column = np.full(3 * n, -1, dtype=np.int64)
        column[_dofs(self.prescribed)] = np.arange(3 * self.prescribed.size)
        freed = _padded(self.base.stiffness, 3 * n)[_dofs(extra)]
        added = (sp.vstack([sp.csr_matrix((self.base.inertia.size, 3 * n)), freed]) + self.change[dofs]).tocoo()
        columns = column[added.col]
        keep = columns >= 0
        return sp.csr_matrix((added.data[keep], (added.row[keep], columns[keep])),
                             shape=(dofs.size, 3 * self.prescribed.size))

    def _modified(self, n: int, extra: np.ndarray, mass: np.ndarray) -> np.ndarray:
        """The free dofs (slots in :attr:`free_nodes` order) where the matrix differs from the base's extended by a
        diagonal: the nodes of changed constraints, of changed masses, the freed ones and their neighbours."""
        touched = np.zeros(n, dtype=bool)
        touched[np.flatnonzero(np.diff(self.change.indptr)) // 3] = True
        moved = ~np.isclose(mass[self.base.free_nodes], self.base.mass, rtol=1e-13, atol=0.0)
        touched[self.base.free_nodes[moved]] = True
        touched[extra] = True
        neighbours = _padded(self.base.stiffness, 3 * n)[_dofs(extra)].indices // 3
        touched[neighbours] = True
        slot = np.full(n, -1, dtype=np.int64)
        slot[self.free_nodes] = np.arange(self.free_nodes.size)
        nodes = slot[np.flatnonzero(touched)]
        nodes = np.sort(nodes[nodes >= 0])
        return _dofs(nodes)

    def implicit_step(self, positions: np.ndarray, velocities: np.ndarray, rest: np.ndarray, forces: np.ndarray,
                      targets: np.ndarray, mass: np.ndarray, dt: float, damping: float) -> None:
        """:meth:`LayerStatics.implicit_step` with the corrected solve (a changed dt factorises the layer anew)."""
        from .static import implicit_rhs, implicit_update

        if dt != self.base.dt:
            if self.refactorised is None:
                self.refactorised = _factorised(self._fresh(), mass, dt)
            self.refactorised.implicit_step(positions, velocities, rest, forces, targets, mass, dt, damping)
            return
        coupling, rhs = self._coupling, np.empty(self._inertia.size)
        implicit_rhs(positions, velocities, rest, self.free_nodes, self._inertia, 1.0 - damping, dt, forces,
                     coupling.indptr, coupling.indices, coupling.data, self.prescribed, targets, rhs)
        rhs -= self._coupling_change @ (targets - rest[self.prescribed]).ravel()
        implicit_update(self._solver.solve(rhs), positions, velocities, rest, self.free_nodes, self.prescribed,
                        targets, dt)

    def displacement(self, forces: np.ndarray, prescribed_displacement: np.ndarray) -> np.ndarray:
        """:meth:`LayerStatics.displacement`, in this layer's free-node order."""
        fresh = self._fresh()
        slot = np.searchsorted(fresh.free_nodes, self.free_nodes)
        return fresh.displacement(forces, prescribed_displacement)[slot]

    def displacement_columns(self, forces: np.ndarray, prescribed_displacement: np.ndarray) -> np.ndarray:
        """:meth:`LayerStatics.displacement_columns`, in this layer's free-node order."""
        fresh = self._fresh()
        rows = _dofs(np.searchsorted(fresh.free_nodes, self.free_nodes))
        ordered = np.zeros_like(forces)
        ordered[rows] = forces
        return fresh.displacement_columns(ordered, prescribed_displacement)[rows]

    @property
    def stiffness(self) -> sp.csr_matrix:
        """``(3n, 3n)`` the layer's stiffness after the cuts [N/m] (built on first use)."""
        if getattr(self, "_stiffness", None) is None:
            self._stiffness = _padded(self.base.stiffness, self.change.shape[0]) + self.change
        return self._stiffness

    def _fresh(self) -> LayerStatics:
        if getattr(self, "_built", None) is None:
            self._built = LayerStatics(self.stiffness, prescribed=self.prescribed)
        return self._built


def _dofs(nodes: np.ndarray) -> np.ndarray:
    return (3 * np.asarray(nodes, dtype=np.int64)[:, None] + np.arange(3)).ravel()


def _diagonal(matrix: sp.csr_matrix, dofs: np.ndarray) -> np.ndarray:
    """``(k,)`` the diagonal entries of ``matrix`` at ``dofs``."""
    return np.asarray(matrix[dofs, dofs]).ravel() if dofs.size else np.zeros(0)


def _padded(matrix: sp.csr_matrix, size: int) -> sp.csr_matrix:
    """``matrix`` as ``(size, size)`` with zero rows and columns appended (new vertices)."""
    rows = matrix.shape[0]
    if rows == size:
        return matrix
    indptr = np.concatenate([matrix.indptr, np.full(size - rows, matrix.indptr[-1])])
    return sp.csr_matrix((matrix.data, matrix.indices, indptr), shape=(size, size))


def _padded_rows(matrix: sp.csr_matrix, rows: int) -> sp.csr_matrix:
    """``matrix`` with empty rows appended up to ``rows``."""
    indptr = np.concatenate([matrix.indptr, np.full(rows - matrix.shape[0], matrix.indptr[-1])])
    return sp.csr_matrix((matrix.data, matrix.indices, indptr), shape=(rows, matrix.shape[1]))
