"""Elastic attachments (ligaments): the Attachment's checks, and springs that every method solves with: a body hung
on them balances its weight, an anchor moved carries the body rigidly, loads superpose, dt does not move the
equilibrium, and a cut keeps them."""

import dataclasses

import numpy as np
import pytest

from tissuesim import HybridMesh, SolverError, make_solver
from tissuesim.errors import BoundaryConditionError
from tissuesim.experiments.protocol import load_node
from tissuesim.experiments.wound import scripted_incision
from tissuesim.mesh import models
from tissuesim.solvers.attachments import Attachment
from tissuesim.solvers import available_solvers, method_names

METHODS = available_solvers()
STATIC = method_names(where=lambda cls: cls.solves_statics())
#: Stepped by a time integrator whose rest is a direct static solve's.
#: The methods a cut carries whose static answer is solved directly.
CUT_STATIC = method_names(cuts=True, where=lambda cls: cls.solves_statics())
STEPPED_TO_STATIC = method_names(where=lambda cls: not cls.static_by_default() and cls.solves_statics())
G = np.array([0.0, 0.0, -9.81])


@pytest.fixture(scope="module")
def cube():
    return HybridMesh.build(models.cube(resolution=386))


@pytest.fixture(scope="module")
def top(cube):
    return load_node(cube.surface.vertices, cube.surface.triangles)


@pytest.fixture(scope="module")
def top_face(cube):
    v = cube.surface.vertices
    return np.flatnonzero(v[:, 2] > v[:, 2].max() - 1e-9)


def rest_under(solver, node, force=(0.0, 0.0, 0.0)):
    """M_S displacements [m] at equilibrium: the static solve, or stepping until the remaining motion is below 1e-8
    of the displacement (mass-spring)."""
    return solver.solve_static(node, force, rtol=1e-8, max_steps=40000) - solver.rest_positions


# ------------------------------------------------------------------------------------------------ the dataclass
@pytest.mark.parametrize("nodes", [[], [-1, 2], [1.5, 2.0], [3, 3], [[1, 2], [3, 4]], ["a"]])
def test_bad_nodes_are_refused(nodes):
    with pytest.raises(BoundaryConditionError, match="attachment's nodes"):
        Attachment(nodes, 10.0)


@pytest.mark.parametrize("stiffness", [0.0, -1.0, np.nan, np.inf, True, "10", None])
def test_bad_stiffness_is_refused(stiffness):
    with pytest.raises(BoundaryConditionError, match="positive finite number"):
        Attachment([1, 2, 3], stiffness)


@pytest.mark.parametrize("anchor", [(0.0, 1.0), (0.0, np.nan, 1.0), "up", [[0, 0, 0]]])
def test_bad_anchor_is_refused(anchor):
    with pytest.raises(BoundaryConditionError, match="anchor is a point"):
        Attachment([1, 2, 3], 10.0, anchor)


def test_an_attachment_is_plain_frozen_data():
    a = Attachment(np.array([4, 1, 7]), 12, (0.0, 0.1, 0.2))
    assert a.nodes.tolist() == [4, 1, 7] and a.nodes.dtype == np.int64 and a.stiffness == 12.0
    assert a.anchor.tolist() == [0.0, 0.1, 0.2]
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.stiffness = 1.0
    with pytest.raises(ValueError):
        a.nodes[0] = 0


def test_nodes_outside_the_surface_and_a_bare_attachment_are_refused(cube, top_face):
    n = cube.surface.vertex_count
    with pytest.raises(BoundaryConditionError, match=f"outside the surface's 0..{n - 1}"):
        make_solver("fem", cube, attachments=(Attachment([0, n + 3], 1.0),))
    with pytest.raises(SolverError, match="tuple of tissuesim Attachment"):
        make_solver("fem", cube, attachments=Attachment(top_face, 1.0))


@pytest.mark.parametrize("method", method_names(material="neo-hookean"))
def test_a_finite_strain_body_hung_on_attachments_balances_its_weight(cube, top, top_face, method):
    """The springs are linear in u in finite strain too (zero rest length, fixed anchors): their total force is
    the weight, and a body stiff enough to strain little hangs as the linear one does."""
    options = dict(fixed=[], attachments=(Attachment(top_face, 50.0),), gravity=G)
    solver = make_solver(method, cube, material="neo-hookean", **options)
    u = rest_under(solver, top)
    weight = 1000.0 * abs(cube.surface.signed_volume) * 9.81
    assert np.allclose(solver.attachment_forces().sum(axis=0), [0.0, 0.0, weight], rtol=1e-8, atol=1e-8 * weight)
    stiff = rest_under(make_solver(method, cube, material="neo-hookean", youngs_modulus=5.5e5, **options), top)
    linear = rest_under(make_solver(method, cube, youngs_modulus=5.5e5, **options), top)
    assert np.abs(stiff - linear).max() <= 1e-3 * np.abs(linear).max()
    assert np.all(np.isfinite(u))
    with pytest.raises(BoundaryConditionError, match="no fixed vertex to move"):
        solver.set_fixed_positions(np.zeros((0, 3)))


def test_the_pbd_projection_forms_refuse_attachments(cube, top_face):
    with pytest.raises(SolverError, match="integrator='implicit'"):
        make_solver("pbd", cube, form="pbd", attachments=(Attachment(top_face, 10.0),))


# ------------------------------------------------------------------------------------------------- the physics
@pytest.mark.parametrize("method", METHODS)
def test_a_body_hung_on_attachments_alone_balances_its_weight(cube, top, top_face, method):
    solver = make_solver(method, cube, fixed=[], attachments=(Attachment(top_face, 50.0),), gravity=G)
    u = rest_under(solver, top)
    weight = 1000.0 * abs(cube.surface.signed_volume) * 9.81
    tolerance = 1e-9 if method in STATIC else 1e-5
    assert np.allclose(solver.attachment_forces().sum(axis=0), [0.0, 0.0, weight], rtol=tolerance,
                       atol=tolerance * weight)
    if method not in STATIC:    # a stiff network needs ~10⁴ substeps a step: the static methods check the rest
        return
    # a stiff body hangs as a rigid one: every node down by the weight over the total spring constant
    stiff = make_solver(method, cube, fixed=[], attachments=(Attachment(top_face, 50.0),), gravity=G,
                        youngs_modulus=5.5e7)
    u = rest_under(stiff, top)
    assert np.allclose(u[:, 2], -weight / 50.0, rtol=1e-3), method


@pytest.mark.parametrize("method", STATIC)
def test_anchors_moved_together_carry_the_body_rigidly(cube, method):
    """Three single-node ligaments whose anchors are their nodes' rest positions shifted by d: the rigid shift by d
    strains nothing and stretches no spring, so it is the equilibrium, whatever E. (The mass-spring network creeps
    toward it algebraically, not geometrically: its flat faces have no first-order stiffness across them; its
    kernel's spring is checked by hand below.)"""
    v = cube.surface.vertices
    nodes = [int(np.argmin(v[:, 0] + v[:, 1])), int(np.argmax(v[:, 0] - v[:, 1])), int(np.argmax(v[:, 2]))]
    shift = np.array([0.002, -0.001, 0.003])
    attachments = tuple(Attachment([i], 20.0, v[i] + shift) for i in nodes)
    solver = make_solver(method, cube, fixed=[], attachments=attachments)
    u = rest_under(solver, nodes[0])
    assert np.abs(u - shift).max() <= 1e-9 * np.abs(shift).max(), method


def test_the_mass_spring_kernel_pulls_an_attached_node_and_weighs_every_free_one_by_hand():
    from tissuesim.solvers.mass_spring import mass_spring_step

    x = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]])
    v = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.5]])
    w = np.array([2.0, 0.0, 4.0])        # node 1 pinned
    anchor = np.array([[0.01, -0.02, 0.03]])
    h, k = 0.001, 30.0
    expected_v = v + h * G + np.array([h * w[0] * k * (anchor[0] - x[0]), [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    expected_v[1] = 0.0
    expected_x = x + h * expected_v
    mass_spring_step(x, v, np.zeros_like(x), w, np.zeros_like(x), np.zeros((0, 2), np.int32), np.zeros(0),
                     np.zeros(0), h, 1, 1.0, np.array([0]), np.array([k]), anchor, G, True)
    assert np.allclose(v, expected_v, rtol=1e-14, atol=1e-17) and np.allclose(x, expected_x, rtol=1e-14, atol=1e-17)


@pytest.mark.parametrize("method", STATIC)
def test_attachments_loads_and_gravity_superpose(cube, top, top_face, method):
    held = (Attachment(top_face[::3], 30.0),)
    both = rest_under(make_solver(method, cube, attachments=held, gravity=G), top, (0.2, 0.0, 0.1))
    weight = rest_under(make_solver(method, cube, attachments=held, gravity=G), top)
    load = rest_under(make_solver(method, cube, attachments=held), top, (0.2, 0.0, 0.1))
    assert np.abs(both - weight - load).max() <= 1e-9 * np.abs(both).max()


@pytest.mark.parametrize("method", STATIC)
def test_an_attachment_stiffens_the_body(cube, top, top_face, method):
    free = rest_under(make_solver(method, cube), top, (0.0, 0.0, 0.2))
    held = rest_under(make_solver(method, cube, attachments=(Attachment(top_face, 100.0),)), top, (0.0, 0.0, 0.2))
    assert 0.0 < held[top, 2] < free[top, 2] or free[top, 2] < held[top, 2] < 0.0


@pytest.mark.parametrize("method", STEPPED_TO_STATIC)
def test_stepping_an_attached_body_ends_at_the_static_answer_for_any_dt(cube, top, top_face, method):
    options = dict(fixed=[], attachments=(Attachment(top_face, 50.0),), gravity=G)
    static = rest_under(make_solver(method, cube, **options), top)
    for dt in (0.005, 0.03):
        solver = make_solver(method, cube, dt=dt, **options)
        previous = solver.positions.copy()
        for _ in range(20000):
            solver.step()
            motion = np.abs(solver.positions - previous).max()
            previous[:] = solver.positions
            if motion < 1e-13:
                break
        assert np.abs(solver.displacements - static).max() <= 1e-7 * np.abs(static).max(), dt


def test_the_mass_spring_step_stays_stable_with_a_stiff_attachment(cube, top_face):
    """The substep bound counts the attachment springs: a ligament far stiffer than the network does not blow up."""
    solver = make_solver("mass-spring", cube, fixed=[], attachments=(Attachment(top_face, 1e5),), gravity=G)
    plain = make_solver("mass-spring", cube)
    assert solver.omega_max > plain.omega_max
    for _ in range(200):
        solver.step()
    assert np.abs(solver.displacements).max() < 0.01


@pytest.fixture(scope="module")
def off_the_cut(cube, top_face):
    """Top-face vertices a scripted incision (along x, through the top's centre) leaves where they are."""
    v = cube.surface.vertices
    return top_face[np.abs(v[top_face, 1] - 0.5 * (v[:, 1].min() + v[:, 1].max())) > 0.015]


@pytest.mark.parametrize("method", CUT_STATIC)
def test_a_cut_keeps_the_attachments(cube, top, off_the_cut, method):
    options = dict(fixed=[], attachments=(Attachment(off_the_cut, 40.0),), gravity=G)
    solver = make_solver(method, cube, **options)
    scripted_incision(solver)
    carried = rest_under(solver, top)
    fresh = rest_under(make_solver(method, solver.hybrid, **options), top)
    assert np.abs(carried - fresh).max() <= 1e-8 * np.abs(carried).max()


@pytest.mark.parametrize("method", CUT_STATIC)
def test_a_cut_does_not_move_an_attached_vertex(cube, top, top_face, method):
    """The wound's vertices are moved onto the blade's trace, but not an attached one (as not a fixed one): its
    ligament stays on the point it was built on, and the carried solver stays a fresh one's on the cut mesh."""
    options = dict(fixed=[], attachments=(Attachment(top_face, 40.0),), gravity=G)
    solver = make_solver(method, cube, **options)
    scripted_incision(solver)
    assert np.array_equal(solver.rest_positions[top_face], cube.surface.vertices[top_face])
    carried = rest_under(solver, top)
    fresh = rest_under(make_solver(method, solver.hybrid, **options), top)
    assert np.abs(carried - fresh).max() <= 1e-8 * np.abs(carried).max()


def test_the_mass_spring_cut_keeps_the_attachments_in_its_substep_bound(cube, off_the_cut):
    options = dict(fixed=[], attachments=(Attachment(off_the_cut, 1e4),), gravity=G)
    solver = make_solver("mass-spring", cube, **options)
    scripted_incision(solver)
    fresh = make_solver("mass-spring", solver.hybrid, **options)
    assert np.isclose(solver.omega_max, fresh.omega_max, rtol=1e-9)
