"""The simulator's second hand (pin-heads left holding), its support brush and the solver options a scene gives it,
driven through the controller's pointer events as the window drives them."""

import numpy as np
import pytest

from tissuesim import HybridMesh, SolverError
from tissuesim.mesh import models
from tissuesim.viewer.controller import Controller, Settings
from tissuesim.solvers import method_names

DOWN = np.array([0.0, 0.0, -1.0])  # a camera looking straight down
EYE = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def hybrid():
    return HybridMesh.build(models.sphere(resolution=300))


def surface_point(controller, direction):
    """The current surface vertex farthest along ``direction`` (3,)."""
    x = controller.solver.positions
    return x[np.argmax(x @ np.asarray(direction, dtype=float))].copy()


def grab_and_pull(controller, point, pull):
    """Click at ``point``, drag the cursor by ``pull`` (3,) m in the camera plane (seen from straight above)."""
    controller.pointer_down(point, EYE + point, DOWN)
    target = point + np.asarray(pull, dtype=float)
    controller.pointer_move(None, target + [0.0, 0.0, 1.0], DOWN)


def test_a_pin_head_let_go_with_hold_keeps_its_load_beside_a_second_grab(hybrid):
    c = Controller(hybrid, settings=Settings(method="hybrid", stiffness=20.0))
    first = surface_point(c, [1.0, 0.0, 1.0])
    grab_and_pull(c, first, [0.01, 0.0, 0.0])
    held_node, held_force = c.pin.node, c.force.copy()
    c.pointer_up(hold=True)
    assert len(c.held) == 1 and len(c.solver.loads) == 1
    np.testing.assert_allclose(c.solver.loads[0].force, held_force, rtol=0, atol=1e-15)  # assigned, not computed

    second = surface_point(c, [-1.0, 0.0, 1.0])
    grab_and_pull(c, second, [-0.01, 0.0, 0.0])
    assert c.pin.node != held_node and len(c.solver.loads) == 2
    c.pointer_up()                                             # the live pin-head lets go; the held one acts on
    assert [load.node for load in c.solver.loads] == [held_node]
    c.key("x")
    assert len(c.held) == 0 and c.solver.loads == ()


def test_held_pin_heads_follow_a_change_of_method_and_of_stiffness(hybrid):
    c = Controller(hybrid, settings=Settings(method="hybrid", stiffness=20.0))
    point = surface_point(c, [0.0, 1.0, 1.0])
    grab_and_pull(c, point, [0.0, 0.01, 0.0])
    c.pointer_up(hold=True)
    node = c.held.nodes[0]
    c.configure(method="embedded")
    assert c.solver.name == "embedded" and [load.node for load in c.solver.loads] == [node]
    np.testing.assert_allclose(np.linalg.norm(c.solver.loads[0].force), 0.2, rtol=1e-12)   # 20 N/m × 1 cm
    c.configure(stiffness=40.0)
    np.testing.assert_allclose(np.linalg.norm(c.solver.loads[0].force), 0.4, rtol=1e-12)
    c.reset()
    assert len(c.held) == 0 and c.solver.loads == ()


def test_two_pin_heads_held_at_once_give_the_sum_of_each_alone(hybrid):
    """The hybrid is linear: the two held loads superpose (equilibria by solve_static, to round-off)."""
    displacements = []
    for pulls in ([0], [1], [0, 1]):
        c = Controller(hybrid, settings=Settings(method="hybrid", stiffness=20.0))
        spots = [surface_point(c, [1.0, 0.2, 1.0]), surface_point(c, [-1.0, -0.2, 1.0])]
        for which in pulls:
            grab_and_pull(c, spots[which], [0.0, 0.0, 0.01] if which == 0 else [0.01, 0.0, 0.0])
            c.pointer_up(hold=True)
        displacements.append(c.solver.solve_static() - c.solver.rest_positions)
    first, second, both = displacements
    np.testing.assert_allclose(both, first + second, rtol=0, atol=1e-9 * np.abs(both).max())


def test_painting_the_support_fixes_the_painted_vertices_and_keeps_a_held_pin_head(hybrid):
    c = Controller(hybrid, settings=Settings(method="hybrid", stiffness=20.0))
    point = surface_point(c, [1.0, 0.0, 1.0])
    grab_and_pull(c, point, [0.01, 0.0, 0.0])
    c.pointer_up(hold=True)
    c.set_mode("support")
    side = surface_point(c, [0.0, -1.0, 0.0])
    c.pointer_down(side, side + [0.0, -1.0, 0.0], [0.0, 1.0, 0.0])
    c.pointer_move(side + [0.0, 0.0, 0.01], side + [0.0, -1.0, 0.01], [0.0, 1.0, 0.0])
    c.pointer_up()
    painted = c.support
    assert painted is not None and painted.size >= 3
    np.testing.assert_array_equal(c.solver.fixed, painted)
    near = np.linalg.norm(hybrid.surface.vertices - side, axis=1) <= c.brush.radius
    assert set(np.flatnonzero(near)) <= set(painted.tolist())
    assert len(c.solver.loads) == 1 and len(c.held) == 1      # the held pin-head came over to the new solver
    c.set_support(None)
    assert c.support is None and c.solver.fixed.size and not np.array_equal(c.solver.fixed, painted)


def test_solver_options_reach_every_solver_built_and_settings_own_theirs(hybrid):
    c = Controller(hybrid, settings=Settings(method="hybrid"), solver_options={"density": 600.0})
    assert c.solver.density == 600.0
    c.configure(method="pbd")
    assert c.solver.density == 600.0
    with pytest.raises(SolverError, match="youngs_modulus.*Settings"):
        Controller(hybrid, solver_options={"youngs_modulus": 9000.0})


@pytest.fixture(scope="module")
def finer():
    """A surface fine enough under the probe for its contact to settle (a 300-vertex sphere puts 3-7 vertices
    under it, which the embedded method's coarse tets cannot all hold on the sphere)."""
    return HybridMesh.build(models.sphere(resolution=1000))


def press_probe(controller, *, frames=20):
    top = surface_point(controller, [0.0, 0.0, 1.0])
    controller.set_mode("probe")
    controller.pointer_down(top, EYE + top, DOWN)
    for _ in range(frames):
        controller.advance(controller.settings.dt)
    return top


@pytest.mark.parametrize("method", method_names(where=lambda cls: cls.gravity_caveat is None))     # a volume
def test_the_probe_presses_where_it_is_put_pushes_up_on_itself_and_lets_go(finer, method):
    c = Controller(finer, settings=Settings(method=method))
    press_probe(c)
    probe = c.probe.probe
    assert probe is not None and probe.contacts.size >= 3
    force = probe.force
    assert force[2] > 5.0 * np.linalg.norm(force[:2])   # the tissue pushes it back up
    assert probe.gaps().min() > -0.01 * c.probe.radius  # the contact solved: no vertex more than 1 % of R inside
    x = c.solver.positions.copy()
    c.advance(10 * c.settings.dt)
    np.testing.assert_allclose(c.solver.positions, x, rtol=0, atol=1e-6 * c.solver.size)   # held still, it rests
    c.pointer_up()
    assert c.probe.probe is None and c.solver.loads == ()


def test_a_held_probe_stays_through_a_mode_switch_and_a_change_of_method_and_x_withdraws_it(finer):
    c = Controller(finer, settings=Settings(method="hybrid"))
    press_probe(c)
    c.pointer_up(hold=True)
    c.set_mode("pin")
    assert c.probe.pressing and len(c.solver.loads) >= 1
    c.configure(method="embedded")
    assert c.solver.name == "embedded" and c.probe.probe.solver is c.solver and len(c.solver.loads) >= 1
    c.key("x")
    assert not c.probe.pressing and c.solver.loads == ()


def test_gravity_switched_on_in_the_simulator_sags_the_model_and_off_brings_it_back(hybrid):
    c = Controller(hybrid, settings=Settings(method="hybrid"))
    c.set_solver_option("gravity", (0.0, 0.0, -9.81))
    assert c.solver.gravity is not None and c.notice == ""
    sag = c.solver.solve_static() - c.solver.rest_positions
    # down, mostly: the coarse sphere is not symmetric, so it leans a little (measured 3.8 times less than it sags)
    assert sag[:, 2].mean() < 0.0 and -sag[:, 2].mean() > 2.0 * np.abs(sag[:, :2].mean(axis=0)).max()
    c.set_solver_option("gravity", None)
    assert c.solver.gravity is None
    np.testing.assert_allclose(c.solver.solve_static(), c.solver.rest_positions, rtol=0, atol=1e-15)


def test_a_painted_ligament_holds_with_its_stiffness_and_a_bad_option_changes_nothing(hybrid):
    c = Controller(hybrid, settings=Settings(method="hybrid"))
    c.set_mode("support")
    c.brush.paints, c.brush.ligament_stiffness = "ligament", 300.0
    side = surface_point(c, [1.0, 0.0, 0.5])
    c.pointer_down(side, side + [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0])
    c.pointer_up()
    (ligament,) = c.solver_options["attachments"]
    assert ligament.stiffness == 300.0 and ligament.nodes.size >= 1
    np.testing.assert_array_equal(np.sort(c.solver.attached_nodes), np.sort(ligament.nodes))
    solver = c.solver
    c.set_solver_option("gravity", (0.0, 0.0))            # not 3 numbers: refused, nothing changed
    assert c.solver is solver and "gravity" in c.notice and "gravity" not in c.solver_options
    c.set_solver_option("attachments", None)
    assert c.solver.attached_nodes.size == 0


SIDE = np.array([0.0, 1.0, 0.0])   # a camera looking along +y: its plane is x-z, so a drag can lift


def grasp_and_carry(controller, point, motion, *, frames=10):
    """Press the grasper at ``point`` seen from the side, drag the jaws by ``motion`` (3,) m in the camera plane,
    and let ``frames`` frames pass."""
    controller.pointer_down(point, point - SIDE, SIDE)
    controller.pointer_move(None, point + np.asarray(motion, dtype=float) - SIDE, SIDE)
    for _ in range(frames):
        controller.advance(controller.settings.dt)


def off_target(grasper):
    """The largest distance [m] of a held vertex from where its jaws put it."""
    return float(np.linalg.norm(grasper.targets() - grasper.solver.positions[grasper.held], axis=1).max())


def test_the_grasper_carries_the_held_patch_where_the_jaws_go_and_lets_go(hybrid):
    c = Controller(hybrid, settings=Settings(method="hybrid"), mode="grasper")
    top = surface_point(c, [0.0, 0.0, 1.0])
    grasp_and_carry(c, top, [0.0, 0.0, 0.01])                          # lifted 10 mm
    grasper = c.grasper.grasper
    assert c.notice == "" and grasper.held.size >= 3
    np.testing.assert_allclose(grasper.position, top + [0.0, 0.0, 0.01], rtol=0, atol=1e-12)
    assert off_target(grasper) <= grasper.tolerance                   # the patch is where the jaws are
    assert c.grasper.force[2] < -5.0 * np.linalg.norm(c.grasper.force[:2])   # the tissue pulls the jaws back down
    assert len(c.solver.loads) == grasper.held.size
    (position, reach), = c.grasper.jaws()
    assert reach == c.grasper.radius and np.array_equal(position, grasper.position)
    c.pointer_up()
    assert not c.grasper.grasping and c.solver.loads == () and c.grasper.jaws() == []


def test_graspers_let_go_with_hold_keep_holding_and_follow_a_change_of_method(hybrid):
    c = Controller(hybrid, settings=Settings(method="hybrid"), mode="grasper")
    grasp_and_carry(c, surface_point(c, [0.0, 0.0, 1.0]), [0.0, 0.0, 0.005])
    c.pointer_up(hold=True)
    grasp_and_carry(c, surface_point(c, [1.0, 0.0, 0.0]), [0.005, 0.0, 0.0])
    c.pointer_up(hold=True)
    held = [(g.held.copy(), g.position.copy()) for g in c.grasper.held]
    assert len(held) == 2 and not c.grasper.grasping
    assert len(c.solver.loads) == sum(patch.size for patch, _ in held)   # both act together
    c.configure(method="fem")
    for grasper, (patch, position) in zip(c.grasper.held, held):
        assert grasper.solver is c.solver
        np.testing.assert_array_equal(grasper.held, patch)
        np.testing.assert_allclose(grasper.position, position, rtol=0, atol=1e-15)
    for _ in range(2):
        c.advance(c.settings.dt)
    # the two patches pull on each other; their forces are solved together, so both sit on their own jaws
    assert all(off_target(g) <= g.tolerance for g in c.grasper.held)
    c.key("x")
    assert c.grasper.held == [] and c.solver.loads == ()


def test_a_grasp_the_grasper_refuses_says_why_and_changes_nothing(hybrid):
    c = Controller(hybrid, settings=Settings(method="hybrid"), mode="grasper")
    bottom = surface_point(c, [0.0, 0.0, -1.0])                     # in the fixed bottom tenth
    x = c.solver.positions.copy()
    c.pointer_down(bottom, bottom - SIDE, SIDE)
    assert "fixed" in c.notice and not c.grasper.grasping and c.solver.loads == ()
    c.pointer_move(None, bottom + [0.0, 0.0, 0.01] - SIDE, SIDE)
    c.advance(c.settings.dt)
    np.testing.assert_array_equal(c.solver.positions, x)
    top = surface_point(c, [0.0, 0.0, 1.0])
    grasp_and_carry(c, top, [0.0, 0.0, 0.005], frames=2)
    c.pointer_up(hold=True)
    loads = c.solver.loads
    c.pointer_down(top, top - SIDE, SIDE)                           # the same patch again: another grasper holds it
    assert "another grasper" in c.notice and not c.grasper.grasping and c.solver.loads == loads
    c.pointer_down(top + [0.0, 0.0, 1.0], top + [0.0, 0.0, 1.0] - SIDE, SIDE)  # nothing within reach
    assert "nothing to grasp" in c.notice and not c.grasper.grasping
