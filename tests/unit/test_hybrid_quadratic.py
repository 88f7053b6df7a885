"""The hybrid's quadratic M_V (``element="quadratic"``): the field every M_S vertex follows, its load, its physics,
and what it refuses."""

import numpy as np
import pytest

import tissuesim
from tissuesim.errors import SolverError
from tissuesim.experiments.protocol import load_node
from tissuesim.fem.quadratic import QuadraticFEM, quadratic_body_force, quadratic_elements, shape_values
from tissuesim.mesh import models
from tissuesim.mesh.regions import nodes_below
from tissuesim.mesh.tetmesh import TetMesh
from tissuesim.solvers.quadratic_field import midside_points

RADIUS = 0.008  # m
FORCE = np.array([0.0, 0.0, -0.3])  # N


@pytest.fixture(scope="module")
def cube():
    return tissuesim.HybridMesh.build(models.cube(400))


@pytest.fixture(scope="module")
def node(cube):
    return load_node(cube.surface.vertices, cube.surface.triangles)


@pytest.fixture(scope="module")
def solver(cube):
    return tissuesim.make_solver("hybrid", cube, element="quadratic")


def test_shape_values_interpolate_quadratics_exactly():
    rng = np.random.default_rng(3)
    corners = rng.normal(size=(4, 3))
    mids = np.array([0.5 * (corners[a] + corners[b]) for a, b in ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))])
    nodes = np.concatenate([corners, mids])
    bary = rng.dirichlet(np.ones(4), size=20)
    values = shape_values(bary)
    field = lambda p: p[:, 0] ** 2 - 3.0 * p[:, 1] * p[:, 2] + p[:, 0]   # noqa: E731  any quadratic
    assert np.allclose(values.sum(axis=1), 1.0, atol=1e-14)
    assert np.allclose(values @ field(nodes), field(bary @ corners), atol=1e-12)


def test_quadratic_body_force_is_the_consistent_load():
    points = np.array([[0.0, 0.0, 0.0], [0.03, 0.0, 0.0], [0.01, 0.02, 0.0], [0.01, 0.01, 0.02]])
    mesh = TetMesh(points, np.array([[0, 1, 2, 3]], dtype=np.int32))
    elements, edges = quadratic_elements(mesh.tets, 4)
    load = quadratic_body_force(mesh, elements, 10, 1000.0, [0.0, 0.0, -9.81])
    weight = 1000.0 * mesh.volumes[0] * -9.81
    assert np.isclose(load[:, 2].sum(), weight, rtol=1e-12)
    # ∫ ρ g v dV for v = x (linear: the nodes interpolate it exactly), against the centroid rule
    x = np.concatenate([points[:, 0], 0.5 * (points[edges[:, 0], 0] + points[edges[:, 1], 0])])
    assert np.isclose(load[:, 2] @ x, weight * points[:, 0].mean(), rtol=1e-12)


def test_the_surface_follows_the_quadratic_fem_of_m_v(cube, node, solver):
    """Every vertex is M_V's quadratic solution (an independent QuadraticFEM, same supports) under the load that
    the embedding's transpose gives it, to 1e-12 of the largest displacement."""
    x = solver.solve_static(node, FORCE, radius=RADIUS)
    volume = cube.volume
    points = np.concatenate([volume.points, midside_points(volume, quadratic_elements(volume.tets,
                                                                                      volume.node_count)[1])])
    fixed = np.zeros(len(points), dtype=bool)
    fixed[nodes_below(points, solver.fixed_height)] = True
    fem = QuadraticFEM(volume, youngs_modulus=solver.youngs_modulus, poisson_ratio=solver.poisson_ratio,
                       fixed=lambda p: fixed)
    nodes, shares = solver.contact_patch(node, RADIUS)
    tets, bary = np.asarray(cube.embedding_tet)[nodes], np.asarray(cube.embedding_barycentric)[nodes]
    forces = np.zeros((fem.node_count, 3))
    np.add.at(forces, fem.elements[tets].ravel(), (shape_values(bary) * shares[:, None]).ravel()[:, None] * FORCE)
    u = fem.solve(forces)
    expected = np.einsum("ik,ikd->id", shape_values(cube.embedding_barycentric),
                         u[fem.elements[np.asarray(cube.embedding_tet)]])
    scale = np.abs(expected).max()
    assert scale > 1e-4
    assert np.allclose(x - solver.rest_positions, expected, atol=1e-12 * scale, rtol=0)
    control = np.asarray(cube.control)
    assert np.allclose(solver.control_displacement, u[np.asarray(cube.control_volume)], atol=1e-12 * scale, rtol=0)
    assert np.allclose(expected[control], u[np.asarray(cube.control_volume)], atol=1e-12 * scale, rtol=0)


def test_physics_first_the_answer_ignores_dt_density_and_iterations_and_scales_as_one_over_e(cube, node, solver):
    base = solver.solve_static(node, FORCE, radius=RADIUS) - solver.rest_positions
    solver.reset()
    for options in ({"density": 2000.0}, {"iterations": 3}):
        other = tissuesim.make_solver("hybrid", cube, element="quadratic", **options)
        assert np.allclose(other.solve_static(node, FORCE, radius=RADIUS) - other.rest_positions, base,
                           atol=1e-12, rtol=0)
    for dt in (0.005, 0.02):
        solver.set_load(node, FORCE, radius=RADIUS)
        for _ in range(3):
            solver.step(dt)
        assert np.allclose(solver.displacements, base, atol=1e-12, rtol=0)
        solver.reset()
    stiff = tissuesim.make_solver("hybrid", cube, element="quadratic", youngs_modulus=2 * solver.youngs_modulus)
    assert np.allclose(stiff.solve_static(node, FORCE, radius=RADIUS) - stiff.rest_positions, base / 2,
                       atol=1e-12, rtol=0)
    double = solver.solve_static(node, 2 * FORCE, radius=RADIUS) - solver.rest_positions
    solver.reset()
    assert np.allclose(double, 2 * base, atol=1e-12, rtol=0)


def test_loads_superpose_and_the_fixed_vertices_stay(cube, node, solver):
    other = int(np.argmax(cube.surface.vertices[:, 0] + cube.surface.vertices[:, 2]))   # a free top corner
    solver.add_load(node, FORCE, radius=RADIUS)
    solver.add_load(other, [0.1, 0.0, 0.0])
    both = solver.solve_static() - solver.rest_positions
    solver.reset()
    one = solver.solve_static(node, FORCE, radius=RADIUS) - solver.rest_positions
    solver.reset()
    two = solver.solve_static(other, [0.1, 0.0, 0.0]) - solver.rest_positions
    solver.reset()
    assert np.allclose(both, one + two, atol=1e-12, rtol=0)
    assert np.all(both[solver.fixed] == 0.0)


def test_gravity_is_the_weight_of_the_body(cube):
    """The consistent load sums to ρ g V of M_V, and the top sags as on the fine FEM's volume (within 3 %: two
    different meshes of the same body)."""
    gravity = (0.0, 0.0, -9.81)
    solver = tissuesim.make_solver("hybrid", cube, element="quadratic", gravity=gravity)
    load = solver.quadratic_field.constant_load
    assert np.isclose(load[:, 2].sum(), solver.density * -9.81 * cube.volume.volumes.sum(), rtol=1e-12)
    x = solver.solve_static() - solver.rest_positions
    assert np.all(x[solver.fixed] == 0.0)
    fine = tissuesim.make_solver("fem", tissuesim.HybridMesh.build(models.cube(400), fine_volume=True),
                                 gravity=gravity)
    top = int(np.argmax(solver.rest_positions[:, 2]))
    sag = (fine.solve_static() - fine.rest_positions)[top, 2]
    assert sag < 0.0 and abs(x[top, 2] / sag - 1.0) < 0.03


def test_finite_strain_converges_and_agrees_with_linear_at_small_load(cube, node):
    small = FORCE / 30.0
    linear = tissuesim.make_solver("hybrid", cube, element="quadratic")
    finite = tissuesim.make_solver("hybrid", cube, element="quadratic", material="neo-hookean")
    a = linear.solve_static(node, small, radius=RADIUS) - linear.rest_positions
    b = finite.solve_static(node, small, radius=RADIUS) - finite.rest_positions
    assert np.abs(b - a).max() < 0.02 * np.abs(a).max()
    finite.reset()
    finite.set_load(node, small, radius=RADIUS)
    for _ in range(60):
        finite.step()
    assert np.abs(finite.displacements - b).max() < 1e-3 * np.abs(b).max()


@pytest.mark.parametrize("options, error", [
    ({"element": "cubic"}, SolverError),
    ({"element": "quadratic", "near_field": 0.015}, SolverError),
])
def test_bad_options_are_refused(cube, options, error):
    with pytest.raises(error, match="element"):
        tissuesim.make_solver("hybrid", cube, **options)


def test_the_contact_compliance_is_the_solvers_own_response(cube, node, solver):
    """The probe's Newton step uses this matrix: vertex j's normal motion under a unit normal force on vertex i,
    as a solve of the same loads gives it (1e-10, with the floor of 1e-9 of the largest entry on the diagonal),
    and symmetric."""
    from tissuesim.solvers.quadratic_field import COMPLIANCE_FLOOR

    rest = solver.rest_positions
    nodes = np.array([node, *np.argsort(np.linalg.norm(rest - rest[node], axis=1))[1:4]])
    normals = np.array([[0.0, 0.0, 1.0], [0.0, 0.6, 0.8], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    compliance = solver.contact_compliance(nodes, normals)
    assert np.allclose(compliance, compliance.T, atol=1e-10 * np.abs(compliance).max(), rtol=0)
    compliance[np.diag_indices(len(nodes))] -= COMPLIANCE_FLOOR * np.diagonal(compliance).max() / (1 + COMPLIANCE_FLOOR)
    for i, vertex in enumerate(nodes):
        u = solver.solve_static(int(vertex), normals[i]) - rest
        solver.reset()
        assert np.allclose(np.einsum("jd,jd->j", normals, u[nodes]), compliance[:, i],
                           atol=1e-10 * np.abs(compliance).max(), rtol=0)
    neo = tissuesim.make_solver("hybrid", cube, element="quadratic", material="neo-hookean")
    assert neo.contact_compliance(nodes, normals) is None      # the probe models it (finite strain)


@pytest.mark.parametrize("material", ["linear", "neo-hookean"])
def test_a_body_hung_on_attachments_balances_its_weight(cube, node, material):
    """No support but springs on the top face: their total force is the weight (the cube's M_V encloses M_S's
    volume), linear and finite strain; the body hangs below its rest place."""
    from tissuesim.solvers.attachments import Attachment

    v = cube.surface.vertices
    top_face = np.flatnonzero(v[:, 2] > v[:, 2].max() - 1e-9)
    solver = tissuesim.make_solver("hybrid", cube, element="quadratic", material=material, fixed=[],
                                   attachments=(Attachment(top_face, 50.0),), gravity=(0.0, 0.0, -9.81))
    u = solver.solve_static(node, (0.0, 0.0, 0.0), rtol=1e-8) - solver.rest_positions
    weight = solver.density * abs(cube.surface.signed_volume) * 9.81
    assert np.allclose(solver.attachment_forces().sum(axis=0), [0.0, 0.0, weight], rtol=1e-8, atol=1e-8 * weight)
    assert u[:, 2].max() < 0.0


def test_a_base_moved_rigidly_carries_the_body_rigidly(cube):
    """Finite strain: the base turned and shifted, no load: every vertex goes with the same rigid motion (1e-9 of
    the body's size), and back at rest after a reset."""
    solver = tissuesim.make_solver("hybrid", cube, element="quadratic", material="neo-hookean")
    angle = 0.3
    turn = np.array([[np.cos(angle), -np.sin(angle), 0.0], [np.sin(angle), np.cos(angle), 0.0], [0.0, 0.0, 1.0]])
    shift = np.array([0.01, -0.02, 0.005])
    rest = solver.rest_positions
    solver.set_fixed_positions(rest[solver.fixed] @ turn.T + shift)
    x = solver.solve_static()
    size = np.ptp(rest, axis=0).max()
    assert np.abs(x - (rest @ turn.T + shift)).max() < 1e-9 * size
    solver.reset()
    assert np.abs(solver.positions - rest).max() < 1e-12


def test_a_cut_frees_its_lips_and_the_rest_follows_m_v(cube, node):
    """After a cut the vertices of the changed triangles are the layer's; every other vertex is still M_V's
    quadratic field; the lips part under a pull, and a refused move changes nothing."""
    solver = tissuesim.make_solver("hybrid", cube, element="quadratic")
    rest = solver.rest_positions
    top = rest[:, 2].max()
    start = np.array([rest[:, 0].min() + 0.015, 0.0, top])
    scalpel = tissuesim.Scalpel(solver)
    assert solver.static                     # every vertex on M_V's field: a step is the static answer
    scalpel.press(start)
    scalpel.move(start + [0.03, 0.0, 0.0])
    scalpel.release()
    assert not solver.static                 # the freed lips are the layer's: a step relaxes them
    n = len(solver.positions)
    assert n > len(rest)
    free = np.setdiff1d(np.arange(n), solver.prescribed)
    assert free.size > 0 and np.all(free >= 0)
    copies = np.arange(len(rest), n)
    twins = [(int(np.flatnonzero(np.all(solver.rest_positions[:len(rest)] == solver.rest_positions[c], axis=1))[0]),
              int(c)) for c in copies if np.any(np.all(solver.rest_positions[:len(rest)] == solver.rest_positions[c],
                                                       axis=1))]
    assert twins, "the cut duplicated no vertex"
    lip, other = max(twins, key=lambda pair: solver.rest_positions[pair[0], 2])
    assert lip in free and other in free
    moved = solver.solve_static(lip, [0.0, 0.0, 0.05]) - solver.rest_positions
    held = solver.prescribed[~np.isin(solver.prescribed, solver.fixed)]
    field = solver.quadratic_field.linear_displacement(solver.loads)
    assert np.allclose(moved[held], field[held], atol=1e-12, rtol=0)
    assert moved[lip, 2] > 0.0 and np.linalg.norm(moved[lip] - moved[other]) > 0.1 * moved[lip, 2]  # lips part
    solver.reset()
    assert np.abs(solver.positions - solver.rest_positions).max() < 1e-12


def test_a_probe_presses_over_a_cut_and_on_a_coarse_volume(cube, node):
    """Where the exact compliance is singular (a cut's copy shares its original's embedding; more contact vertices
    than the coarse field's dofs under them) the probe still converges: freed vertices get the probe's model, and
    the field's compliance has a floor."""
    solver = tissuesim.make_solver("hybrid", cube, element="quadratic")
    rest = solver.rest_positions
    top = rest[:, 2].max()
    scalpel = tissuesim.Scalpel(solver)
    start = np.array([rest[node, 0] - 0.015, rest[node, 1], top])
    scalpel.press(start)
    scalpel.move(start + [0.03, 0.0, 0.0])
    scalpel.release()
    probe = tissuesim.Probe(solver, radius=0.03)
    probe.press_static(rest[node] + [0.0, 0.0, 0.028])          # 2 mm deep
    assert probe.residual <= probe.tolerance and probe.force[2] > 0.0
    coarse = tissuesim.HybridMesh.build(models.cube(1000), target_vertices=30, fine_volume=False)
    wide = tissuesim.Probe(tissuesim.make_solver("hybrid", coarse, element="quadratic"), radius=0.06)
    wide.press_static([0.0, 0.0, coarse.surface.vertices[:, 2].max() + 0.06 - 0.004])
    assert wide.residual <= wide.tolerance and wide.force[2] > 0.0


def test_the_kept_point_responses_never_drop_those_asked_for(cube, monkeypatch):
    import tissuesim.solvers.quadratic_field as quadratic_field

    solver = tissuesim.make_solver("hybrid", cube, element="quadratic")
    field = solver.quadratic_field
    monkeypatch.setattr(quadratic_field, "KEPT_BYTES", 5 * 9 * 8 * field.node_count)    # five vertices' worth
    top = np.flatnonzero(solver.rest_positions[:, 2] > solver.rest_positions[:, 2].max() - 1e-9)[:8]
    all_at_once = field.point_responses(top)                # more than are kept
    field.point_responses(top[:4])
    again = field.point_responses(top[[0, 5, 6]])           # the oldest kept one, and two new ones
    assert np.array_equal(again, all_at_once[[0, 5, 6]])
    assert len(field._points) == 5


def test_vertices_a_cut_moves_get_their_new_embedding(cube):
    solver = tissuesim.make_solver("hybrid", cube, element="quadratic")
    rest = solver.rest_positions
    top = rest[:, 2].max()
    scalpel = tissuesim.Scalpel(solver)
    start = np.array([rest[:, 0].min() + 0.013, 0.0031, top])       # beside a row of vertices: they snap onto it
    scalpel.press(start)
    scalpel.move(start + [0.05, 0.0, 0.0])
    scalpel.release()
    field, mesh = solver.quadratic_field, solver.hybrid
    assert np.array_equal(field.nodes, field.fem.elements[np.asarray(mesh.embedding_tet)])
    assert np.allclose(field.values, shape_values(mesh.embedding_barycentric), atol=1e-15, rtol=0)


def test_contacts_whose_responses_would_not_fit_get_the_probes_model(cube, monkeypatch):
    import tissuesim.solvers.quadratic_field as quadratic_field

    solver = tissuesim.make_solver("hybrid", cube, element="quadratic")
    nodes, normals = np.arange(6), np.tile([0.0, 0.0, 1.0], (6, 1))
    assert solver.contact_compliance(nodes, normals) is not None
    monkeypatch.setattr(quadratic_field, "KEPT_BYTES", 5 * 9 * 8 * solver.quadratic_field.node_count)
    assert solver.contact_compliance(nodes, normals) is None
