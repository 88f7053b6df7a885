"""Sweep items F4, F5: a refused or failed cutting move changes nothing, for every method that cuts, and the solver
steps, resets and cuts on afterwards as if the move had never been tried."""

import numpy as np
import pytest

from tissuesim import HybridMesh, Scalpel, SolverError, make_solver
from tissuesim.cutting.invariants import check_cut_invariants
from tissuesim.solvers import method_names
from tissuesim.solvers.cut_carry import anchored_nodes, carrier_class, cut_updater
from tissuesim.mesh import models

#: the methods the scalpel cuts
METHODS = method_names(cuts=True)
#: of those, the methods that refuse a cut leaving a piece no prescribed node holds (the embedded method keeps it)
REFUSING_LOOSE = method_names(cuts=True, where=lambda cls: not carrier_class(cls).keeps_loose)
#: the moves of a short stroke across the cube's top, a little off the mesh's lines [m]
STROKE = [[x, 0.0013, 0.085] for x in (-0.0101, -0.0052, 0.0007, 0.0061)]


@pytest.fixture(scope="module")
def cube():
    return HybridMesh.build(models.cube(resolution=386), fine_volume=False)


def _state(solver):
    """Copies of everything a move may change: the state, the surface and the method's per-vertex and constraint
    arrays."""
    arrays = {"positions": solver.positions, "velocities": solver.velocities, "rest": solver.rest_positions,
              "triangles": solver.hybrid.surface.triangles, "forces": solver.forces, "fixed": solver.fixed,
              "control": solver.hybrid.control, "embedding": solver.hybrid.embedding_tet}
    for name in ("mass", "inv_mass", "prescribed", "targets", "springs", "rest_lengths", "stiffness"):
        if hasattr(solver, name):
            arrays[name] = getattr(solver, name)
    if hasattr(solver, "applied_forces"):
        arrays["applied"] = solver.applied_forces()
    constraints = getattr(solver, "constraints", None)
    for name in ("edges", "rest_length", "bending", "rest_angle"):
        if constraints is not None:
            arrays[name] = getattr(constraints, name)
    return {name: np.array(value) for name, value in arrays.items()}


def _assert_same(before, after):
    assert before.keys() == after.keys()
    for name in before:
        assert before[name].shape == after[name].shape, name
        assert np.array_equal(before[name], after[name]), name      # nothing written: exact


def _deformed(cube, method):
    """A solver cut by the first half of the stroke, deformed by a held load beside it."""
    solver = make_solver(method, cube)
    scalpel = Scalpel(solver, depth=0.01)
    scalpel.press(STROKE[0], direction=[0, 0, -1])
    scalpel.move(STROKE[1])
    top = np.flatnonzero(np.isclose(solver.rest_positions[:, 2], solver.rest_positions[:, 2].max()))
    node = int(top[np.argmin(np.linalg.norm(solver.rest_positions[top] - [0.0, 0.01, 0.08], axis=1))])
    solver.set_load(node, [0.0, 0.1, 0.1], radius=0.004)
    for _ in range(3):
        solver.step()
    return solver, scalpel


@pytest.mark.parametrize("error, raised", [(IndexError("index 1403 is out of bounds for axis 0 with size 1380"),
                                             SolverError), (KeyboardInterrupt(), KeyboardInterrupt)])
@pytest.mark.parametrize("stage", ["_update_lumped", "update", "_reload"])
@pytest.mark.parametrize("method", METHODS)
def test_a_move_that_fails_while_it_is_written_is_taken_back(cube, method, stage, error, raised):
    """An error after a stage of the move has written its part (the surface and lumped areas; the method's
    constraints, masses and prescribed nodes; the held load re-applied), like the sweep's F5 IndexError, or an
    interrupt there: the move is taken back, an internal error comes out as a SolverError, an interrupt as itself."""
    solver, scalpel = _deformed(cube, method)
    updater = cut_updater(solver)
    real = getattr(updater, stage)

    def failing(*args):
        real(*args)
        raise error

    setattr(updater, stage, failing)
    before = _state(solver)
    load = solver.load_nodes.copy(), solver.load_shares.copy()
    with pytest.raises(raised, match=r"IndexError.*taken back.*as before the move" if raised is SolverError else None):
        scalpel.move(STROKE[2])
    delattr(updater, stage)
    assert np.array_equal(solver.load_nodes, load[0]) and np.array_equal(solver.load_shares, load[1])
    _assert_same(before, _state(solver))
    # the same moves and steps as a solver that never tried it, bit for bit
    twin, twin_scalpel = _deformed(cube, method)
    for s, sc in ((solver, scalpel), (twin, twin_scalpel)):
        sc.move(STROKE[2])
        sc.move(STROKE[3])
        for _ in range(3):
            s.step()
    _assert_same(_state(twin), _state(solver))
    h = solver.hybrid
    assert check_cut_invariants(h.surface.vertices, h.surface.triangles, anchored=anchored_nodes(solver)) == []
    solver.reset()
    assert np.array_equal(solver.positions, solver.rest_positions)


def _square(solver):
    """A closed square stroke on the cube's top: it cuts a patch out of the surface, which no node holds."""
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]]) * 0.006 + [0.0011, 0.0013]
    points = [np.array([x, y, 0.081]) for x, y in corners]
    scalpel = Scalpel(solver, depth=0.004)
    scalpel.press(points[0], direction=[0, 0, -1])
    return scalpel, [a + f * (b - a) for a, b in zip(points, points[1:]) for f in (1 / 3, 2 / 3, 1.0)]


@pytest.mark.parametrize("method", REFUSING_LOOSE)
def test_a_refused_loose_piece_changes_nothing(cube, method):
    solver = make_solver(method, cube)
    scalpel, moves = _square(solver)
    for k, point in enumerate(moves):
        before = _state(solver)
        try:
            scalpel.move(point)
        except SolverError as error:
            assert "separate a piece" in str(error)
            break
    else:
        pytest.fail("the square was not refused")
    assert k >= len(moves) - 3          # refused when it closes, not before
    _assert_same(before, _state(solver))
    solver.set_load(int(np.argmax(solver.rest_positions[:, 2])), [0.0, 0.0, 0.1])
    for _ in range(3):
        solver.step()
    assert np.all(np.isfinite(solver.positions))


@pytest.mark.parametrize("method", METHODS)
def test_a_move_that_fails_while_it_is_planned_changes_nothing(cube, method, monkeypatch):
    """An internal error before anything is written (in the planning of the cut) comes out as a SolverError too."""
    solver, scalpel = _deformed(cube, method)
    surface = cut_updater(solver).surface

    def failing(*args, **kwargs):
        raise ValueError("could not broadcast input array from shape (1403,3) into shape (1380,3)")

    monkeypatch.setattr(surface, "plan", failing)
    before = _state(solver)
    with pytest.raises(SolverError, match=r"could not be planned \(ValueError.*nothing was changed"):
        scalpel.move(STROKE[2])
    _assert_same(before, _state(solver))
