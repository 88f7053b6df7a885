"""Solves with a stale factor and an exact low-rank correction (fem/factor_update.py), and the layer's step after
cutting moves on it (layer/cut_statics.py): both equal a fresh factorisation's answer to round-off."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import tissuesim
from tissuesim.fem.factor_update import CorrectedSolve, ExplicitFactor, SparseColumns
from tissuesim.mesh import models
from tissuesim.layer.cut_statics import CutLayerStatics
from tissuesim.solvers import method_names
from tissuesim.solvers.surface_layer import SurfaceLayerSolver

LAYER = method_names(where=lambda cls: issubclass(cls, SurfaceLayerSolver))     # the surface-layer methods

RNG = np.random.default_rng(7)


def _grid_laplacian(side: int) -> sp.csc_matrix:
    n = side * side
    off = np.ones(n - 1)
    off[side - 1::side] = 0.0      # no wrap-around between grid rows
    lap = sp.diags([4.0 * np.ones(n), -off, -off, -np.ones(n - side), -np.ones(n - side)], [0, 1, -1, side, -side])
    return (lap + 0.1 * sp.eye(n)).tocsc()


def test_explicit_factor_solves_and_its_sparse_columns_are_the_dense_ones():
    matrix = _grid_laplacian(20)
    base = ExplicitFactor(matrix, np.arange(matrix.shape[0]))
    b = RNG.normal(size=matrix.shape[0])
    np.testing.assert_allclose(matrix @ base.backward(base.forward(b)), b, atol=1e-12)
    for dof in (0, 137, 399):
        rows, values = base.unit_column(dof)
        dense = base.forward(np.eye(1, matrix.shape[0], dof).ravel())
        assert np.count_nonzero(dense[np.setdiff1d(np.arange(dense.size), rows)]) == 0   # exact zeros off the path
        np.testing.assert_allclose(values, dense[rows], rtol=1e-13, atol=1e-15)


def test_a_corrected_solve_with_extra_dofs_and_an_indefinite_change_is_exact():
    base_matrix = _grid_laplacian(20)
    n0, extra = base_matrix.shape[0], 4
    matrix = sp.lil_matrix((n0 + extra, n0 + extra))
    matrix[:n0, :n0] = base_matrix
    touched = [150, 151, 170, 171]
    for i in touched:             # a softened patch (the change is negative definite there) ...
        for j in touched:
            matrix[i, j] -= 0.4 if i == j else 0.1
    for k in range(extra):        # ... and new dofs tied to it
        matrix[n0 + k, n0 + k] = 3.0
        matrix[n0 + k, touched[k]] = matrix[touched[k], n0 + k] = -1.0
    matrix = matrix.tocsc()
    diagonal = matrix.diagonal()[n0:]
    modified = np.array(touched + list(range(n0, n0 + extra)))
    stale = sp.block_diag([base_matrix, sp.diags(diagonal)]).tocsc()
    base = ExplicitFactor(base_matrix, np.arange(n0))
    columns = SparseColumns(base)
    columns.take([399, 150])      # columns kept from an earlier correction, one of them not needed now
    solve = CorrectedSolve(columns, modified=modified, difference=(matrix - stale)[modified][:, modified].toarray(),
                           extra_diagonal=diagonal)
    b = RNG.normal(size=n0 + extra)
    exact = spla.spsolve(matrix, b)
    assert np.abs(solve.solve(b) - exact).max() <= 1e-12 * np.abs(exact).max()
    rows, g, gram = columns.take(touched)
    np.testing.assert_allclose(gram, g.T @ g, rtol=1e-13, atol=1e-15)   # grown block by block, still GᵀG


def _cut_session(method: str, moves: int = 6):
    """A hybrid or pbd solver on a small sphere under a load, cut progressively over its top; yields after each
    move the solver with its load applied to the state (the step's own preparation done)."""
    hybrid = tissuesim.HybridMesh.build(models.sphere(2000), fine_volume=False)
    solver = tissuesim.make_solver(method, hybrid)
    x = solver.positions
    top = int(np.argmax(x[:, 2]))
    solver.set_load(top, (0.1, 0.0, 0.3), radius=0.004)
    for _ in range(3):
        solver.step()
    centre = x.mean(axis=0)
    radius = np.linalg.norm(x[top] - centre)

    def on(angle):
        direction = np.array([np.sin(angle), 0.1, np.cos(angle)])
        return centre + (radius + 0.001) * direction / np.linalg.norm(direction)

    scalpel = tissuesim.Scalpel(solver, depth=0.01)
    scalpel.press(on(-0.3), direction=[0, 0, -1])
    for angle in np.linspace(-0.27, 0.3, moves):
        scalpel.move(on(angle))
        solver._prepare_static()
        yield solver


@pytest.mark.parametrize("method", LAYER)
def test_the_step_after_each_cutting_move_equals_a_freshly_factorised_layers(method):
    corrected = 0
    for solver in _cut_session(method):
        state = solver.positions.copy(), solver.velocities.copy()
        statics = solver.built_statics
        solver.step()
        stepped = solver.positions.copy()
        solver.state.positions[:], solver.state.velocities[:] = state
        solver.built_statics = None            # the layer factorised again as it stands
        solver.step()
        fresh = solver.positions - solver.rest_positions
        assert np.abs(stepped - solver.positions).max() <= 1e-10 * np.abs(fresh).max()
        corrected += isinstance(statics, CutLayerStatics)
        solver.built_statics = statics
        solver.state.positions[:] = stepped
    assert corrected >= 4      # most moves went through the correction, not a refactorisation


def _step_against_fresh(solver) -> float:
    """One step with the solver's layer as it is, against one with the layer factorised afresh from the same
    state: the largest difference over the fresh step's largest displacement."""
    state = solver.positions.copy(), solver.velocities.copy()
    statics = solver.built_statics
    solver.step()
    stepped = solver.positions.copy()
    solver.state.positions[:], solver.state.velocities[:] = state
    solver.built_statics = None
    solver.step()
    error = np.abs(stepped - solver.positions).max() / np.abs(solver.positions - solver.rest_positions).max()
    solver.built_statics = statics
    solver.state.positions[:] = stepped
    return error


def test_past_the_limit_of_touched_dofs_the_layer_is_factorised_again_and_corrected_on(monkeypatch):
    from tissuesim.layer import cut_statics

    monkeypatch.setattr(cut_statics, "MAX_MODIFIED", 60)
    kinds = []
    for solver in _cut_session("hybrid", moves=8):
        kinds.append(type(solver.built_statics).__name__)
        assert _step_against_fresh(solver) <= 1e-10
    assert "LayerStatics" in kinds[1:] and kinds[-1] == "CutLayerStatics"    # refactorised, then corrected again


def test_a_new_dt_between_cuts_is_factorised_once_and_stays_exact(monkeypatch):
    from tissuesim.layer.static import LayerStatics

    factorisations = []
    factorise = LayerStatics.dynamic_factor
    monkeypatch.setattr(LayerStatics, "dynamic_factor",
                        lambda self, mass, dt: factorisations.append(dt) or factorise(self, mass, dt))
    for k, solver in enumerate(_cut_session("pbd", moves=6)):
        if k == 2:
            solver.dt = 0.5 * solver.dt
        assert _step_against_fresh(solver) <= 1e-10
    # besides the fresh layers of the check: the first steps, and one for the new dt
    assert factorisations.count(factorisations[-1]) - 4 == 1


def test_without_an_explicit_factor_each_cut_refactorises_the_layer_as_before(monkeypatch):
    from tissuesim.layer import cut_statics

    def unavailable(self, statics):
        raise ImportError("cvxopt")

    monkeypatch.setattr(cut_statics._Base, "__init__", unavailable)
    for solver in _cut_session("hybrid", moves=3):
        assert not isinstance(solver.built_statics, CutLayerStatics)
        assert _step_against_fresh(solver) <= 1e-10


def test_a_long_cut_moves_over_to_a_base_built_in_the_background_and_stays_exact(monkeypatch):
    from tissuesim.layer import cut_statics

    monkeypatch.setattr(cut_statics, "RENEW_MODIFIED", 30)
    bases = []
    for solver in _cut_session("hybrid", moves=8):
        statics = solver.built_statics
        if isinstance(statics, CutLayerStatics):
            bases.append(statics.base)
            if statics.base.successor is not None:
                statics.base.successor.result()      # as if the moves came slower than its factorisation
        assert _step_against_fresh(solver) <= 1e-10
    assert len(set(map(id, bases))) >= 2       # went on from a new base without a refactorisation in a move
