"""Sweep item F1: a cut that leaves a piece of surface without a fixed or control node is refused on every move,
whatever the path of the cut, and the invariant checker finds such a piece on its own."""

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from tissuesim import HybridMesh, Scalpel, SolverError, make_solver
from tissuesim.cutting.invariants import check_cut_invariants
from tissuesim.solvers import method_names
from tissuesim.solvers.cut_carry import anchored_nodes, carrier_class
from tissuesim.mesh import models

#: the methods the scalpel cuts that refuse a cut leaving a piece no prescribed node holds (the embedded method
#: keeps such a piece, held by its embedding: its cut carrier ``keeps_loose``)
REFUSING_LOOSE = method_names(cuts=True, where=lambda cls: not carrier_class(cls).keeps_loose)


@pytest.fixture(scope="module")
def cube():
    return HybridMesh.build(models.cube(), fine_volume=False)


def _cut_then_load(solver):
    """The sweep's reproduction up to its last move: a cut, a load that deforms the lip, the load withdrawn."""
    scalpel = Scalpel(solver, depth=0.026207010902498544)
    scalpel.press([0.010931690474996453, -0.035769072807982936, 0.08215106953899248])
    scalpel.move([0.014472407031629109, -0.043629932231718314, 0.08])
    solver.set_load(811, [0.13823476975691854, -0.25981738966588436, -0.05818996870129524])
    for _ in range(5):
        solver.step()
    solver.clear_load()
    return scalpel


LAST_MOVE = [0.022577131113289222, -0.04181529547692052, 0.0792109985407762]


def _unheld_vertices(triangles, n, held):
    """Vertices of the pieces holding none of ``held`` (scipy's components: independent of the cutting code)."""
    tri = np.asarray(triangles, dtype=np.int64)
    rows = np.repeat(np.arange(len(tri)), 3)
    incidence = coo_matrix((np.ones(rows.size), (tri.ravel(), rows)), shape=(n, len(tri))).tocsr()
    _, label = connected_components(incidence @ incidence.T, directed=False)
    return int(np.count_nonzero(~np.isin(label, label[held])))


def _slit_then_flap(solver):
    """A straight slit across the cube's top, then a U-shaped stroke that starts and ends inside two of the slit's
    cut edges: the flap between them comes loose. This is the sweep's F1 in its plainest form: a point inserted on
    an edge an earlier move had cut closes a loop that no cut edge of this move closes (on the sweep's deformed
    cube, a second move's cut began on the first's edge)."""
    y0, top = 0.0013, 0.08
    scalpel = Scalpel(solver, depth=0.004)
    scalpel.press([-0.021, y0, top + 0.001], direction=[0, 0, -1])
    for x in np.linspace(-0.021, 0.021, 8)[1:]:
        scalpel.move([x, y0, top + 0.001])
    scalpel.release()
    tri = np.asarray(solver.hybrid.surface.triangles, dtype=np.int64)
    rest = solver.rest_positions
    edges, count = np.unique(np.sort(tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0, return_counts=True)
    lips = edges[count == 1]
    middle = 0.5 * (rest[lips[:, 0]] + rest[lips[:, 1]])
    length = np.linalg.norm(rest[lips[:, 0]] - rest[lips[:, 1]], axis=1)
    # the middles of the two longest cut edges near x = ∓8 mm (no snapping onto a vertex there)
    p, q = (middle[np.argmin(np.abs(middle[:, 0] - x) + 10.0 * (length < 0.6 * length.max()))] for x in (-0.008, 0.008))
    scalpel.press(p + [0, 0, 0.001], direction=[0, 0, -1])
    path = [p, p + [0, 0.006, 0], q + [0, 0.006, 0], q]
    return scalpel, [a + f * (b - a) + [0, 0, 0.001] for a, b in zip(path, path[1:]) for f in (0.5, 1.0)]


@pytest.mark.parametrize("method", REFUSING_LOOSE)
def test_a_flap_cut_loose_is_refused_and_nothing_changes(cube, method):
    solver = make_solver(method, cube)
    scalpel, moves = _slit_then_flap(solver)
    for point in moves[:-1]:
        scalpel.move(point)
    before = {name: np.array(getattr(solver, name)) for name in ("positions", "velocities", "rest_positions")}
    triangles = np.array(solver.hybrid.surface.triangles)
    with pytest.raises(SolverError, match=r"separate a piece of \d+ surface vertices .*not applied .*cut elsewhere"):
        scalpel.move(moves[-1])
    for name, value in before.items():
        assert np.array_equal(getattr(solver, name), value), name      # a refusal writes nothing: exact
    assert np.array_equal(solver.hybrid.surface.triangles, triangles)
    h = solver.hybrid
    assert check_cut_invariants(h.surface.vertices, h.surface.triangles, anchored=anchored_nodes(solver)) == []
    solver.set_load(int(np.argmax(solver.rest_positions[:, 2])), [0.0, 0.0, 0.1])
    for _ in range(3):
        solver.step()
    assert np.all(np.isfinite(solver.positions))


def test_the_embedded_method_keeps_the_flap_and_reports_it_truthfully(cube):
    solver = make_solver("embedded", cube)
    scalpel, moves = _slit_then_flap(solver)
    reports = [scalpel.move(point) for point in moves]
    h = solver.hybrid
    loose = _unheld_vertices(h.surface.triangles, len(h.surface.vertices), solver.fixed)
    assert loose > 0
    assert reports[-1].loose_vertices == loose
    assert all(r.loose_vertices == 0 for r in reports[:-1])
    assert "hold no anchored" in check_cut_invariants(h.surface.vertices, h.surface.triangles,
                                                      anchored=solver.fixed)[0]


def test_the_embedded_reports_add_up_to_the_loose_vertices_as_the_flap_grows_and_splits(cube):
    """Cuts inside a flap already loose, then one across it: each vertex counts once, in the move it comes loose
    (the sweep saw reports add up to 50 for 35 loose vertices, and 109 for 41)."""
    solver = make_solver("embedded", cube)
    scalpel, moves = _slit_then_flap(solver)
    total = sum(scalpel.move(point).loose_vertices for point in moves)
    scalpel.release()
    y0, top = 0.0013, 0.08
    strokes = [[[x, y0 + 0.003, top + 0.001] for x in np.linspace(-0.005, 0.005, 5)],        # inside the flap
               [[0.002, y, top + 0.001] for y in np.linspace(y0 - 0.0005, y0 + 0.0065, 6)]]  # across it
    for stroke in strokes:
        scalpel.press(stroke[0], direction=[0, 0, -1])
        for point in stroke[1:]:
            total += scalpel.move(point).loose_vertices
            h = solver.hybrid
            assert total == _unheld_vertices(h.surface.triangles, len(h.surface.vertices), solver.fixed)
        scalpel.release()
    assert total > 0


def test_the_sweeps_reproduction_leaves_no_loose_piece(cube):
    """The sweep's own script: whether its last move cuts a piece loose depends on how the load deformed the lip,
    so the test asks what must hold either way: the move is refused, or every piece holds a prescribed node."""
    solver = make_solver("pbd", cube)
    scalpel = _cut_then_load(solver)
    try:
        scalpel.move(LAST_MOVE)
    except SolverError as error:
        assert "separate a piece" in str(error)
    h = solver.hybrid
    assert _unheld_vertices(h.surface.triangles, len(h.surface.vertices), solver.prescribed) == 0


def test_the_checker_finds_a_piece_without_an_anchored_node():
    """Two disjoint cubes, one anchored: the other is a loose piece, whatever made it."""
    a = models.cube(resolution=386)
    v = np.concatenate([a.vertices, a.vertices + [1.0, 0.0, 0.0]])
    t = np.concatenate([a.triangles, a.triangles + len(a.vertices)])
    problems = check_cut_invariants(v, t, anchored=np.array([0]))
    assert len(problems) == 1
    assert f"1 piece ({len(a.vertices)} vertices; first: {len(a.vertices)})" in problems[0]
    assert check_cut_invariants(v, t, anchored=np.array([0, len(a.vertices)])) == []
    assert check_cut_invariants(v, t) == []            # the check is asked for, as the others that need data


@pytest.mark.parametrize("method, control", [("hybrid", True), ("pbd", False), ("mass-spring", False)])
def test_the_anchored_nodes_are_what_the_method_prescribes(cube, method, control):
    solver = make_solver(method, cube)
    anchored = anchored_nodes(solver)
    expected = np.union1d(solver.fixed, cube.control) if control else np.asarray(solver.fixed)
    assert np.array_equal(np.unique(anchored), expected)
    assert anchored_nodes(make_solver("embedded", cube)) is None


def test_releasing_the_last_control_node_of_a_piece_is_refused(cube):
    """A square cut out around one control node of the hybrid stays held by it; a slit through that node inside
    the square releases it without splitting anything, and would leave the square held by nothing."""
    solver = make_solver("hybrid", cube)
    rest, top = solver.rest_positions, solver.rest_positions[:, 2].max()
    on_top = cube.control[np.isclose(rest[cube.control, 2], top)]
    node = int(on_top[np.argmin(np.linalg.norm(rest[on_top, :2], axis=1))])      # the top's middle one
    others = np.setdiff1d(cube.control, [node])
    assert np.linalg.norm(rest[others] - rest[node], axis=1).min() > 0.0065     # none inside the square
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]]) * 0.004 + rest[node, :2] + [0.0011, 0.0013]
    points = [np.array([x, y, top + 0.001]) for x, y in corners]
    scalpel = Scalpel(solver, depth=0.004)
    scalpel.press(points[0], direction=[0, 0, -1])
    for a, b in zip(points, points[1:]):
        for f in (1 / 3, 2 / 3, 1.0):
            scalpel.move(a + f * (b - a))
    h = solver.hybrid
    assert _unheld_vertices(h.surface.triangles, solver.node_count, anchored_nodes(solver)) == 0
    assert _unheld_vertices(h.surface.triangles, solver.node_count, solver.fixed) > 0      # the square is cut out
    scalpel.release()
    scalpel.press(rest[node] + [-0.0024, 0.0007, 0.001], direction=[0, 0, -1])
    before = np.array(solver.positions), np.array(h.surface.triangles), np.array(solver.prescribed)
    with pytest.raises(SolverError, match=r"separate a piece of \d+ surface vertices \(first: "):
        scalpel.move(rest[node] + [0.0024, 0.0007, 0.001])
    after = solver.positions, solver.hybrid.surface.triangles, solver.prescribed
    assert all(np.array_equal(a, b) for a, b in zip(before, after))
    assert node in solver.prescribed
