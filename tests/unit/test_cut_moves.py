"""Vertices moved onto the cut: the wound follows the blade, and every method's rest state follows the moves."""

import numpy as np
import pytest

from tissuesim import HybridMesh, Scalpel, make_solver
from tissuesim.cutting import Sweep, cut_surface
from tissuesim.cutting.invariants import check_cut_invariants
from tissuesim.experiments.wound import lip_deviation
from tissuesim.mesh import models
from tissuesim.solvers.cut_carry import anchored_nodes, cut_updater
from tissuesim.solvers import method_names

METHODS = method_names(cuts=True)
#: a stroke 1.3 mm off a row of the 386-vertex cube's 10 mm grid (0.13 of an edge: it snapped onto the row before)
Y = 0.0013
STROKE = [[x, Y, 0.081] for x in (-0.0101, -0.0052, 0.0007, 0.0061, 0.0113)]


@pytest.fixture(scope="module")
def cube():
    return HybridMesh.build(models.cube(resolution=386), fine_volume=False)


def _cut(cube, method, moved):
    """A solver after the stroke; ``moved`` collects the vertices each move put onto the cut."""
    solver = make_solver(method, cube)
    updater = cut_updater(solver)
    apply = updater.surface.apply

    def recording(plan, sweep):
        moved.extend(plan.moves.vertices.tolist())
        return apply(plan, sweep)

    updater.surface.apply = recording
    scalpel = Scalpel(solver, depth=0.01)
    scalpel.press(STROKE[0], direction=[0, 0, -1])
    for point in STROKE[1:]:
        scalpel.move(point)
    return solver


@pytest.mark.parametrize("method", METHODS)
def test_the_wound_lies_on_the_trace_and_the_body_stays_at_rest(cube, method):
    mass = getattr(make_solver(method, cube), "mass", None)      # the embedded surface has no masses of its own
    moved = []
    solver = _cut(cube, method, moved)
    assert moved, "the stroke should move vertices of the row beside it"
    h = solver.hybrid
    edge = cube.built_edge_length
    line = (np.array(STROKE[0]), np.array(STROKE[-1]))
    deviation = lip_deviation(h.surface.vertices, h.surface.triangles, line, depth=0.01, edge=edge)
    assert deviation["max"] < 1e-9                       # on the trace, to round-off (was 0.13 of an edge)
    assert np.allclose(h.surface.vertices[moved, 1], Y, atol=1e-12, rtol=0.0)
    kept = np.setdiff1d(np.arange(cube.surface.vertex_count), moved)
    assert np.array_equal(h.surface.vertices[kept], cube.surface.vertices[kept])     # nothing else moved
    constraints = getattr(solver, "constraints", None)
    lengths = {}
    if constraints is not None:
        live = constraints.edges[:, 0] != constraints.edges[:, 1]
        lengths = {"edges": constraints.edges[live], "rest_length": constraints.rest_length[live]}
    masses = {} if mass is None else {"masses": solver.mass, "total_mass": mass.sum()}
    assert check_cut_invariants(h.surface.vertices, h.surface.triangles, positions=solver.positions,
                                anchored=anchored_nodes(solver), **lengths, **masses) == []
    # the rest state is the equilibrium: stepping an unloaded cut body moves nothing (1 nm: round-off of the steps)
    for _ in range(20):
        solver.step()
    assert np.abs(solver.positions - solver.rest_positions).max() < 1e-9


def test_a_moved_vertex_keeps_its_tet_and_coarse_triangle_with_coordinates_of_where_it_is(cube):
    moved = []
    solver = _cut(cube, "hybrid", moved)
    h = solver.hybrid
    assert np.array_equal(h.embedding_tet[moved], cube.embedding_tet[moved])
    assert np.array_equal(h.coarse_triangle[moved], cube.coarse_triangle[moved])
    corners = h.volume.points[h.volume.tets[h.embedding_tet[moved]]]
    assert np.allclose(np.einsum("kj,kjd->kd", h.embedding_barycentric[moved], corners), h.surface.vertices[moved],
                       rtol=0.0, atol=1e-12)
    assert np.allclose(h.coarse_barycentric[moved].sum(axis=1), 1.0, rtol=0.0, atol=1e-12)
    # a control node moved onto the cut is released (§7: control nodes on the cut are)
    assert not np.isin(moved, h.control).any()


def test_fixed_and_loaded_vertices_may_not_move_control_nodes_may(cube):
    solver = make_solver("hybrid", cube)
    fixed, control = int(solver.fixed[0]), int(np.setdiff1d(cube.control, solver.fixed)[0])
    free, loaded = np.setdiff1d(np.arange(cube.surface.vertex_count),
                                np.concatenate([cube.control, solver.fixed]))[[0, -1]].tolist()
    solver.set_load(loaded, [0.0, 0.0, 0.01])
    movable = cut_updater(solver).movable(np.array([fixed, control, free, loaded]))
    assert movable.tolist() == [False, True, True, False]


def test_the_pure_cut_moves_only_what_it_is_let_move(cube):
    rest, triangles = cube.surface.vertices, cube.surface.triangles
    sweep = Sweep.between(STROKE[1], STROKE[3], [0.0, 0.0, -0.01])
    free = cut_surface(rest, rest, np.zeros_like(rest), triangles, sweep)
    held = cut_surface(rest, rest, np.zeros_like(rest), triangles, sweep,
                       movable=lambda v: np.zeros(len(v), dtype=bool))
    assert len(free.moved) and not len(held.moved)
    assert np.array_equal(held.rest[: len(rest)], rest)
    for result in (free, held):
        assert check_cut_invariants(result.rest, result.triangles) == []
