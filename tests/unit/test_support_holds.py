"""Supports that do not hold the body are refused by every method, up front, the same way: no fixed vertex, one,
two, or all on one line leave a rigid motion free (before, pbd and mass-spring took them and drifted, and the FEM
methods refused them only in their volume's terms); attachments count as holding."""

import numpy as np
import pytest

from tissuesim import HybridMesh, Scalpel, make_solver
from tissuesim.errors import BoundaryConditionError
from tissuesim.fem.linear import LinearFEM
from tissuesim.fem.rigid_modes import connected_pieces
from tissuesim.mesh import models
from tissuesim.mesh.regions import bottom_nodes
from tissuesim.mesh.tetmesh import structured_box
from tissuesim.solvers.attachments import Attachment, check_supports_hold
from tissuesim.solvers import available_solvers

METHODS = available_solvers()


@pytest.fixture(scope="module")
def cube():
    return HybridMesh.build(models.cube(resolution=386))


@pytest.fixture(scope="module")
def held_sets(cube):
    """Control nodes of the bottom face (so every method's volume has them as nodes too)."""
    v, control = cube.surface.vertices, cube.control
    bottom = control[v[control, 2] < v[:, 2].min() + 1e-9]
    edge = bottom[np.abs(v[bottom, 1] - v[bottom, 1].min()) < 1e-9]       # on one bottom edge: a line
    corner = bottom[[np.argmin(v[bottom, 0] + v[bottom, 1])]]
    far = bottom[[np.argmax(v[bottom, 0] + v[bottom, 1])]]
    return {"none": np.zeros(0, dtype=np.int64), "one": corner, "two": np.concatenate([corner, far]),
            "a line": edge, "the bottom": bottom}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case,why", [("none", "no fixed vertex and no attachment holds it"),
                                      ("one", "a single held vertex"), ("two", "lie on one line"),
                                      ("a line", "lie on one line")])
def test_supports_that_leave_a_rigid_motion_free_are_refused_by_every_method(cube, held_sets, method, case, why):
    with pytest.raises(BoundaryConditionError, match=f"do not hold the body for the {method} method: ") as error:
        make_solver(method, cube, fixed=held_sets[case])
    assert why in str(error.value)
    assert "fix at least three vertices of it that are not on one line" in str(error.value)
    assert "attachments=" in str(error.value)


@pytest.mark.parametrize("method", METHODS)
def test_attachments_complete_supports_that_alone_would_not_hold(cube, held_sets, method):
    v = cube.surface.vertices
    top = np.flatnonzero(v[:, 2] > v[:, 2].max() - 1e-9)
    solver = make_solver(method, cube, fixed=held_sets["a line"], attachments=(Attachment(top[:5], 10.0),))
    solver.set_load(int(top[0]), [0.0, 0.0, -0.05])
    for _ in range(20):
        solver.step()
    assert np.all(np.isfinite(solver.positions)) and 0.0 < np.abs(solver.displacements).max() < 0.01
    with pytest.raises(BoundaryConditionError, match="a single held vertex"):
        make_solver(method, cube, fixed=[], attachments=(Attachment(top[:1], 10.0),))


def _loaded(method, cube, fixed, top) -> np.ndarray:
    """``(n, 3)`` positions [m] under 0.05 N down on ``top``: the static answer, or for mass-spring (whose flat faces
    of springs have no first-order stiffness across them, so it does not settle to a tolerance) after 2 s of steps."""
    solver = make_solver(method, cube, fixed=fixed)
    if method != "mass-spring":
        return solver.solve_static(top, [0.0, 0.0, -0.05])
    solver.set_load(top, [0.0, 0.0, -0.05])
    for _ in range(round(2.0 / solver.dt)):
        solver.step()
    return solver.positions


@pytest.mark.parametrize("method", METHODS)
def test_three_non_collinear_fixed_vertices_hold(cube, held_sets, method):
    v = cube.surface.vertices
    top = int(np.argmax(v[:, 2]))
    moved = {}
    for name, fixed in (("three", held_sets["the bottom"][[0, 5, 11]]), ("the bottom", held_sets["the bottom"])):
        positions = _loaded(method, cube, fixed, top)
        assert np.array_equal(positions[fixed], v[fixed]), name    # held exactly: copies of the rest rows
        moved[name] = np.abs(positions - v).max()
    # Held by three vertices the body carries the load: it moves (measured 0.2-12 mm, about twice as much as with
    # the whole bottom held), but by less than 3 cm, where a free body of 0.5 kg would have been carried 0.2 m off in
    # 2 s by 0.05 N.
    assert 0.0 < moved["the bottom"] <= moved["three"] < 0.03, moved


def test_every_piece_of_a_surface_must_be_held():
    """Two separate tetrahedra' surfaces: held vertices on one leave the other free, and the message says which."""
    tet = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]])
    faces = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    rest = np.concatenate([tet, tet + [0.05, 0.0, 0.0]])
    count, pieces = connected_pieces(np.concatenate([faces, faces + 4]), 8)
    assert count == 2
    check_supports_hold(rest, pieces, np.array([0, 1, 2, 4, 5, 6]), np.zeros(0, dtype=np.int64), "pbd")
    with pytest.raises(BoundaryConditionError, match=r"a piece of the body \(4 surface vertices, first: 4"):
        check_supports_hold(rest, pieces, np.array([0, 1, 2]), np.zeros(0, dtype=np.int64), "pbd")
    check_supports_hold(rest, pieces, np.array([0, 1, 2]), np.array([4, 5, 7]), "pbd")


def test_a_surface_piece_that_the_volume_holds_needs_no_support_of_its_own():
    """A closed square stroke cuts a patch out of the cube's top surface; the embedded method keeps it (its M_V
    holds it). A fresh embedded solver on the cut mesh accepts it; a surface method, which has no volume, refuses."""
    hybrid = HybridMesh.build(models.cube())
    solver = make_solver("embedded", hybrid)
    top = solver.rest_positions[:, 2].max()
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]]) * 0.006 + [0.0011, 0.0013]
    points = [np.array([x, y, top + 0.001]) for x, y in corners]
    scalpel = Scalpel(solver, depth=0.004)
    scalpel.press(points[0], direction=[0, 0, -1])
    for a, b in zip(points, points[1:]):
        for f in np.linspace(0, 1, 4)[1:]:
            scalpel.move(a + f * (b - a))
    cut = solver.hybrid
    assert connected_pieces(cut.surface.triangles, cut.surface.vertex_count)[0] == 2
    make_solver("embedded", cut)
    make_solver("hybrid", cut)
    with pytest.raises(BoundaryConditionError, match=r"do not hold a piece of the body \(\d+ surface vertices"):
        make_solver("pbd", cut)


def test_the_linear_fem_counts_its_springs_as_supports():
    mesh = structured_box([0.02, 0.02, 0.04], [2, 2, 4])
    top = np.flatnonzero(mesh.points[:, 2] > 0.04 - 1e-12)
    nodes, weights = top[:, None], np.ones((top.size, 1))
    fem = LinearFEM(mesh, fixed=np.zeros(0, dtype=np.int64), springs=(nodes, weights, np.full(top.size, 5.0)))
    forces = np.zeros((mesh.node_count, 3))
    forces[:, 2] = -1e-3
    u = fem.solve(forces)
    spring_force = -5.0 * u[top].sum(axis=0)            # k (0 − u) on each held node
    assert np.allclose(spring_force, [0.0, 0.0, 1e-3 * mesh.node_count], rtol=1e-9)
    line = top[np.abs(mesh.points[top, 1]) < 1e-12]
    with pytest.raises(BoundaryConditionError, match="fixed dofs and springs leave 1 rigid-body mode"):
        LinearFEM(mesh, fixed=np.zeros(0, dtype=np.int64), springs=(line[:, None], np.ones((line.size, 1)),
                                                                   np.full(line.size, 5.0)))
    with pytest.raises(BoundaryConditionError, match="no fixed node"):
        LinearFEM(mesh, fixed=np.zeros(0, dtype=np.int64))
    LinearFEM(mesh, fixed=bottom_nodes(mesh.points))        # the usual supports still hold
