"""The grasper: the held patch goes exactly where the jaws carry it (translation and rotation), the reaction is the
fem's nodal reaction for that prescribed displacement, an answer that does not depend on dt, masses or the
iteration's model, every method and material, tools acting together, through a cut, and the refusals."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from scipy.spatial.transform import Rotation

from tissuesim import BoundaryConditionError, Grasper, HybridMesh, PinHead, Probe, SolverError, make_solver
from tissuesim.mesh import models
from tissuesim.solvers import available_solvers
from tissuesim.solvers.registry import solver_class

JAWS = 2.5e-3     # [m] the jaws' reach
LIFT = np.array([0.0, 0.0, 1e-3])    # [m]


@pytest.fixture(scope="module")
def hybrid():
    # 40 × 40 × 20 mm, 1 mm edges within 8 mm of the top's centre, 5 mm beyond: 549 vertices
    return HybridMesh.build(models.indentation_block(width=0.04, height=0.02, fine_edge=1e-3, fine_radius=8e-3,
                                                     coarse_edge=5e-3))


def grip_point(hybrid, x=0.0):
    return np.array([x, 0.0, float(hybrid.surface.vertices[:, 2].max())])


def dirichlet_reaction(solver, held, targets):
    """The fine volume's own answer with the held vertices prescribed at ``targets``: K_ff u_f = −K_fp u_p, and the
    reaction on the jaws −(K u)_p summed (a partitioned solve, not the grasper's force iteration)."""
    fem = solver.fem
    nodes = solver.surface_nodes[held]
    u = np.zeros((fem.node_count, 3))
    u[nodes] = targets - solver.rest_positions[held]
    prescribed = np.zeros(3 * fem.node_count, dtype=bool)
    prescribed[(3 * nodes[:, None] + np.arange(3)).ravel()] = True
    free = np.setdiff1d(fem.free_dofs, np.flatnonzero(prescribed))
    stiffness = fem.stiffness.tocsr()
    flat = u.ravel()
    flat[free] = spla.spsolve(stiffness[free][:, free].tocsc(), -stiffness[free][:, prescribed] @ flat[prescribed])
    reactions = (stiffness @ flat).reshape(-1, 3)
    return -reactions[nodes].sum(axis=0), flat.reshape(-1, 3)


def test_the_held_patch_goes_where_the_jaws_carry_it_and_the_reaction_is_the_fems(hybrid):
    solver = make_solver("fem", hybrid)
    grasper = Grasper(solver, radius=JAWS, tolerance=1e-12)
    point = grip_point(hybrid)
    held = grasper.grab(point)
    assert held.size >= 7 and np.all(np.linalg.norm(solver.rest_positions[held] - point, axis=1) <= JAWS)
    turn = Rotation.from_rotvec([0.0, 0.05, 0.0]).as_matrix()
    force = grasper.move_to(point + LIFT + [0.5e-3, 0.0, 0.0], turn)
    targets = point + LIFT + [0.5e-3, 0.0, 0.0] + (solver.rest_positions[held] - point) @ turn.T
    assert np.abs(solver.positions[held] - targets).max() <= 1e-12      # the patch carried exactly
    assert grasper.iterations == 1          # the fem's own compliance: one Newton step solves a linear model
    expected, field = dirichlet_reaction(solver, held, targets)
    assert np.linalg.norm(force - expected) <= 1e-8 * np.linalg.norm(expected)
    surface_field = field[solver.surface_nodes]
    assert np.abs(solver.positions - solver.rest_positions - surface_field).max() <= 1e-9 * np.abs(
        surface_field).max()
    assert force[2] < 0.0                   # lifted: the tissue pulls the jaws down


def test_the_torque_is_the_reactions_moment_and_grows_with_the_turn(hybrid):
    solver = make_solver("fem", hybrid)
    grasper = Grasper(solver, radius=JAWS, tolerance=1e-12)
    point = grip_point(hybrid)
    grasper.grab(point)
    torques = []
    for angle in (0.02, 0.04):
        grasper.move_to(point, Rotation.from_rotvec([angle, 0.0, 0.0]).as_matrix())
        arms = solver.positions[grasper.held] - point
        nodal = np.array([load.force for load in solver.loads])
        assert np.allclose(grasper.torque, -np.cross(arms, nodal).sum(axis=0), rtol=0, atol=1e-15)
        torques.append(grasper.torque)
    assert torques[0][0] < 0.0               # turned about +x, the tissue turns the jaws back
    # linear: twice the turn, twice the torque (up to the arms' own turn, second order in the angle)
    assert abs(torques[1][0] / torques[0][0] - 2.0) <= 0.01


def test_a_grasper_held_still_leaves_the_body_at_rest_for_every_method(hybrid):
    for method in available_solvers():
        solver = make_solver(method, hybrid)
        grasper = Grasper(solver, radius=JAWS)
        grasper.grab(grip_point(hybrid))
        grasper.move_to(grip_point(hybrid))
        assert grasper.iterations == 0, method
        assert np.array_equal(solver.positions, solver.rest_positions), method
        assert np.array_equal(grasper.force, np.zeros(3)), method


STATIC_METHODS = [(method, material) for method in sorted(available_solvers()) if method != "mass-spring"
                  for material in solver_class(method).materials]


@pytest.mark.parametrize(("method", "material"), STATIC_METHODS)
def test_every_method_and_material_carries_the_patch_to_its_targets(hybrid, method, material):
    solver = make_solver(method, hybrid, material=material)
    grasper = Grasper(solver, radius=JAWS)
    grasper.grab(grip_point(hybrid))
    force = grasper.move_to(grip_point(hybrid) + LIFT)
    assert np.linalg.norm(grasper.targets() - solver.positions[grasper.held], axis=1).max() <= grasper.tolerance
    assert force[2] < 0.0 and abs(force[0]) < 0.2 * abs(force[2])


def test_the_mass_spring_surface_follows_frame_by_frame(hybrid):
    # its quasi-static solve steps an explicit integrator (a membrane: a dead load of 0.2 N on the cube does not
    # settle in 20000 steps), so a static move is as slow as its solve_static; a viewer's frames still close in
    solver = make_solver("mass-spring", hybrid)
    grasper = Grasper(solver, radius=JAWS)
    grasper.grab(grip_point(hybrid))
    grasper.settle(grip_point(hybrid) + 0.2 * LIFT, max_iterations=1)
    first = grasper.residual
    for _ in range(3):
        grasper.settle(max_iterations=2)
    assert grasper.residual < 0.5 * first


def test_the_answer_does_not_depend_on_dt_masses_or_the_model(hybrid):
    answers = []
    for options in ({"dt": 0.01}, {"dt": 0.002, "density": 4000.0}):
        solver = make_solver("hybrid", hybrid, **options)
        grasper = Grasper(solver, radius=JAWS, tolerance=1e-9)
        grasper.grab(grip_point(hybrid))
        answers.append(grasper.move_to(grip_point(hybrid) + LIFT))
    # the fem's exact start and the half-space model's reach one answer
    exact = make_solver("fem", hybrid)
    modelled = make_solver("fem", hybrid)
    modelled.point_compliance = None              # no compliance of its own: the grasper models it
    for solver in (exact, modelled):
        grasper = Grasper(solver, radius=JAWS, tolerance=1e-10)
        grasper.grab(grip_point(hybrid))
        answers.append(grasper.move_to(grip_point(hybrid) + LIFT))
    assert np.linalg.norm(answers[0] - answers[1]) <= 1e-4 * np.linalg.norm(answers[0])
    assert np.linalg.norm(answers[2] - answers[3]) <= 1e-6 * np.linalg.norm(answers[2])


def test_graspers_pin_heads_and_the_probe_act_together(hybrid):
    solver = make_solver("fem", hybrid)
    left, right = Grasper(solver, radius=JAWS), Grasper(solver, radius=JAWS)
    left.grab(grip_point(hybrid, -4e-3))
    right.grab(grip_point(hybrid, 4e-3))
    pin = PinHead(solver, stiffness=20.0)
    pin.grab(grip_point(hybrid, 10e-3))
    pin.drag(grip_point(hybrid, 10e-3) + [0.0, 0.0, 0.01])
    probe = Probe(solver, radius=4e-3)
    probe.press_static(grip_point(hybrid, -12e-3) + [0.0, 0.0, 4e-3 - 0.3e-3])
    # the graspers on one solver are solved together: the second move keeps the first one's patch on its jaws
    left.move_to(grip_point(hybrid, -4e-3) + LIFT)
    right.move_to(grip_point(hybrid, 4e-3) - LIFT)
    assert right.iterations == 1               # the fem's own compliance of both patches: one Newton step
    assert np.linalg.norm(left.targets() - solver.positions[left.held], axis=1).max() <= left.tolerance
    assert np.linalg.norm(right.targets() - solver.positions[right.held], axis=1).max() <= right.tolerance
    assert left.force[2] < 0.0 < right.force[2]
    assert len(solver.loads) == left.held.size + right.held.size + 1 + probe.contacts.size


def test_a_grasper_holds_through_a_cut(hybrid):
    from tissuesim import Scalpel

    solver = make_solver("hybrid", hybrid)
    scalpel = Scalpel(solver, depth=2e-3)
    scalpel.press(grip_point(hybrid, -6e-3) - [0.0, 5e-3, 0.0])
    scalpel.move(grip_point(hybrid, -6e-3) + [0.0, 5e-3, 0.0])
    scalpel.release()
    solver.step()
    grasper = Grasper(solver, radius=JAWS)
    grasper.grab(grip_point(hybrid, -4e-3))
    grasper.move_to(grip_point(hybrid, -4e-3) + LIFT)
    assert np.linalg.norm(grasper.targets() - solver.positions[grasper.held], axis=1).max() <= grasper.tolerance
    solver.step()
    assert np.linalg.norm(grasper.targets() - solver.positions[grasper.held], axis=1).max() <= grasper.tolerance


def test_refusals_name_the_defect_and_change_nothing(hybrid):
    solver = make_solver("fem", hybrid)
    grasper = Grasper(solver, radius=JAWS)
    with pytest.raises(SolverError, match="nothing to grasp"):
        grasper.grab(grip_point(hybrid) + [0.0, 0.0, 0.01])
    with pytest.raises(BoundaryConditionError, match="fixed vertices"):
        grasper.grab(solver.rest_positions[solver.fixed[0]])
    with pytest.raises(SolverError, match="holds nothing"):
        grasper.move_to(grip_point(hybrid))
    grasper.grab(grip_point(hybrid))
    other = Grasper(solver, radius=JAWS)
    with pytest.raises(SolverError, match="another grasper"):
        other.grab(grip_point(hybrid, 1e-3))
    with pytest.raises(SolverError, match="not a proper rotation"):
        grasper.move_to(grip_point(hybrid), np.diag([1.0, 1.0, -1.0]))
    assert np.array_equal(solver.positions, solver.rest_positions) and not solver.loads
    grasper.move_to(grip_point(hybrid) + LIFT)
    before, loads = solver.positions.copy(), [load.force.copy() for load in solver.loads]
    with pytest.raises(SolverError, match="did not reach"):
        _never_converges(grasper, grip_point(hybrid) + 2 * LIFT)
    assert np.array_equal(solver.positions, before)
    assert all(np.array_equal(a.force, b) for a, b in zip(solver.loads, loads))
    grasper.release()
    assert not solver.loads
    other.grab(grip_point(hybrid, 1e-3))       # released vertices can be grasped again


def _never_converges(grasper, position):
    """A move that cannot converge: a tolerance below round-off with a model of the wrong size."""
    grasper.tolerance, grasper._jacobian, grasper._learned = 1e-30, None, None
    grasper.solver.point_compliance = None
    try:
        grasper.move_to(position, max_iterations=2)
    finally:
        del grasper.solver.point_compliance
        grasper.tolerance = 1e-3 * JAWS


def test_a_motion_that_inverts_the_volume_is_refused():
    # a coarse 30 × 30 × 12 mm block (2 mm edges under the jaws): twisting the held patch 2.5 rad about the vertical
    # turns the elements around its rim inside out
    small = HybridMesh.build(models.indentation_block(width=0.03, height=0.012, fine_edge=2e-3, fine_radius=5e-3,
                                                      coarse_edge=4e-3))
    solver = make_solver("fem", small, material="neo-hookean")
    grasper = Grasper(solver, radius=4.5e-3)
    grasper.grab(grip_point(small))
    with pytest.raises(SolverError, match="inverts"):
        grasper.move_to(grip_point(small), Rotation.from_rotvec([0.0, 0.0, 2.5]).as_matrix())
    assert np.array_equal(solver.positions, solver.rest_positions) and not solver.loads
    assert np.array_equal(grasper.rotation, np.eye(3))


def test_the_hybrids_own_compliance_is_its_static_answers(hybrid):
    # the paper's hybrid is linear in its loads (M_V and the layer): its compliance among the held vertices, found
    # by two multi-column solves, is what its static solve gives for each unit force (not symmetric: a force on a
    # layer vertex loads M_V through M'_S and the layer at once)
    solver = make_solver("hybrid", hybrid)
    held = np.flatnonzero(np.linalg.norm(solver.rest_positions - grip_point(hybrid), axis=1) <= JAWS)
    compliance = solver.point_compliance(held)
    columns = []
    for node in held:
        for axis in range(3):
            positions = solver.solve_static(int(node), 1e-3 * np.eye(3)[axis])
            columns.append((positions[held] - solver.rest_positions[held]).ravel() / 1e-3)
    expected = np.array(columns).T
    assert np.abs(compliance - expected).max() <= 1e-9 * np.abs(expected).max()


def test_a_finite_strain_hybrid_follows_by_relaxed_updates_and_gets_there(hybrid):
    # its static solve takes seconds at 10k vertices: follow() updates the forces once a frame from its compliance at
    # rest and the step does the rest; the patch reaches its jaws, where the static move puts it
    solver = make_solver("hybrid", hybrid, material="neo-hookean")
    grasper = Grasper(solver, radius=JAWS)
    grasper.grab(grip_point(hybrid))
    for _ in range(40):
        grasper.follow(grip_point(hybrid) + LIFT)
        solver.step()
    assert grasper.iterations == 0                 # no static solve was made
    assert np.linalg.norm(grasper.targets() - solver.positions[grasper.held], axis=1).max() <= grasper.tolerance
    followed = grasper.force
    twin = make_solver("hybrid", hybrid, material="neo-hookean")
    static = Grasper(twin, radius=JAWS)
    static.grab(grip_point(hybrid))
    assert np.linalg.norm(static.move_to(grip_point(hybrid) + LIFT) - followed) <= 0.02 * np.linalg.norm(followed)


def test_the_hybrids_compliance_after_cuts_is_still_its_static_answers(hybrid):
    from tissuesim import Scalpel

    solver = make_solver("hybrid", hybrid)
    scalpel = Scalpel(solver, depth=2e-3)
    scalpel.press(grip_point(hybrid, -6e-3) - [0.0, 6e-3, 0.0])
    for k in range(1, 7):                    # several moves: the layer's statics are corrected, not made anew
        scalpel.move(grip_point(hybrid, -6e-3) + [0.0, 2e-3 * k - 6e-3, 0.0])
        solver.step()
    scalpel.release()
    held = np.flatnonzero(np.linalg.norm(solver.rest_positions - grip_point(hybrid, -4e-3), axis=1) <= JAWS)
    compliance = solver.point_compliance(held)
    columns = []
    for node in held:
        for axis in range(3):
            solver.reset()
            positions = solver.solve_static(int(node), 1e-3 * np.eye(3)[axis])
            columns.append((positions[held] - solver.rest_positions[held]).ravel() / 1e-3)
    expected = np.array(columns).T
    assert type(solver.statics()).__name__ in ("LayerStatics", "CutLayerStatics")
    assert np.abs(compliance - expected).max() <= 1e-8 * np.abs(expected).max()


def test_a_move_onto_the_targets_still_solves_for_the_equilibrium(hybrid):
    # held still on a body that gravity is about to sag, and after a grab again drops the forces: the held vertices
    # sit on their targets, but the answer is the equilibrium, not the forces of the last solve (or none)
    solver = make_solver("fem", hybrid, gravity=(0.0, 0.0, -9.81))
    grasper = Grasper(solver, radius=JAWS)
    grasper.grab(grip_point(hybrid))
    force = grasper.move_to(grip_point(hybrid))
    assert force[2] < 0.0                          # the jaws hold up part of the weight: the tissue pulls them down
    solver.solve_static()
    assert np.linalg.norm(grasper.targets() - solver.positions[grasper.held], axis=1).max() <= grasper.tolerance
    lifted = grasper.move_to(grip_point(hybrid) + LIFT)
    grasper.grab(grasper.position)                 # hold the lifted patch again: its forces were withdrawn
    assert np.linalg.norm(grasper.move_to(grasper.position) - lifted) <= 1e-6 * np.linalg.norm(lifted)


def test_the_jaws_close_on_both_lips_of_a_cut_through_what_they_hold(hybrid):
    from tissuesim import Scalpel

    solver = make_solver("hybrid", hybrid)
    grasper = Grasper(solver, radius=JAWS)
    grasper.grab(grip_point(hybrid))
    grasper.move_to(grip_point(hybrid) + LIFT)
    count = solver.node_count
    scalpel = Scalpel(solver, depth=2e-3)
    scalpel.press(grip_point(hybrid) + [0.0, -5e-3, LIFT[2]])
    scalpel.move(grip_point(hybrid) + [0.0, 5e-3, LIFT[2]])
    scalpel.release()
    grasper.move_to(grip_point(hybrid) + LIFT)
    made = np.arange(count, solver.node_count)
    within = made[np.linalg.norm(solver.positions[made] - grasper.position, axis=1) <= 0.9 * JAWS]
    assert within.size and np.all(np.isin(within, grasper.held))
    assert np.linalg.norm(grasper.targets() - solver.positions[grasper.held], axis=1).max() <= grasper.tolerance


def test_a_rotation_that_is_no_matrix_of_numbers_is_refused_by_name(hybrid):
    from scipy.spatial.transform import Rotation as R

    solver = make_solver("fem", hybrid)
    grasper = Grasper(solver, radius=JAWS)
    grasper.grab(grip_point(hybrid))
    for rotation in ("abc", R.from_rotvec([0.0, 0.0, 0.1]), [[1, 0, 0], [0, 1]], np.full((3, 3), None)):
        with pytest.raises(SolverError, match="rotation must be a"):
            grasper.move_to(grip_point(hybrid), rotation)
    assert not solver.loads and np.array_equal(grasper.rotation, np.eye(3))
    with pytest.raises(AttributeError):
        grasper.solver = make_solver("fem", hybrid)     # one grasper, one solver
