"""The rigid probe: unilateral frictionless contact (no vertex inside beyond the tolerance, push only, along the
probe's normal), an equilibrium that does not depend on dt, masses or iteration caps and scales with the material,
tools acting together, and the refusals."""

import numpy as np
import pytest

from tissuesim import BoundaryConditionError, HybridMesh, PinHead, SolverError, make_solver
from tissuesim.errors import TissuesimWarning
from tissuesim.mesh import models
from tissuesim.tools.probe import Probe

RADIUS = 4e-3     # [m] the probe
DEPTH = 0.5e-3    # [m] how far below the rest surface its lowest point is held


@pytest.fixture(scope="module")
def hybrid():
    # 40 × 40 × 20 mm, 1 mm edges within 8 mm of the top's centre, 5 mm beyond: 549 vertices
    return HybridMesh.build(models.indentation_block(width=0.04, height=0.02, fine_edge=1e-3, fine_radius=8e-3,
                                                     coarse_edge=5e-3))


def top(hybrid) -> float:
    return float(hybrid.surface.vertices[:, 2].max())


def centre(hybrid, x=0.0, depth=DEPTH):
    return np.array([x, 0.0, top(hybrid) + RADIUS - depth])


def test_press_holds_every_vertex_out_and_pushes_only_along_the_normal(hybrid):
    solver = make_solver("fem", hybrid)
    probe = Probe(solver, radius=RADIUS)
    positions = probe.press_static(centre(hybrid))
    gaps = np.linalg.norm(positions - probe.center, axis=1) - RADIUS
    assert gaps.min() >= -probe.tolerance            # no vertex inside beyond the stated tolerance
    assert probe.residual <= probe.tolerance and 1 <= probe.iterations <= 10
    contacts = probe.contacts
    assert contacts.size >= 7                        # a contact disc, not one vertex
    assert np.all(np.abs(gaps[contacts]) <= probe.tolerance)    # every pushed vertex touches the probe
    for load in solver.loads:
        normal = (positions[load.node] - probe.center) / np.linalg.norm(positions[load.node] - probe.center)
        assert np.dot(load.force, normal) > 0.0      # push only
        # no friction: along the normal of the last update, which the last solve turned by the vertex's sliding
        # (about tolerance / R); a friction of coefficient 0.01 would tilt it ten times more
        assert np.linalg.norm(np.cross(load.force, normal)) <= 2e-3 * np.linalg.norm(load.force)
    total = sum(load.force for load in solver.loads)
    assert np.array_equal(probe.force, -total)       # equal and opposite (exactly: the same sum)
    assert probe.force[2] > 0 and abs(probe.force[0]) < 0.05 * probe.force[2]   # pressed straight down


def test_a_converged_press_does_not_change_with_dt_masses_or_iteration_caps(hybrid):
    answers = []
    for options, cap in (({"dt": 0.01}, 60), ({"dt": 0.002, "density": 4000.0}, 200)):
        solver = make_solver("hybrid", hybrid, **options)
        probe = Probe(solver, radius=RADIUS, tolerance=1e-7)
        answers.append((probe.press_static(centre(hybrid), max_iterations=cap), probe.force))
    (x1, f1), (x2, f2) = answers
    # both within 1e-7 m of the same complementarity conditions: the positions agree to a few tolerances
    assert np.abs(x1 - x2).max() <= 5e-7
    assert np.linalg.norm(f1 - f2) <= 1e-3 * np.linalg.norm(f1)


def test_the_force_scales_with_the_material_at_a_given_depth(hybrid):
    forces = []
    for youngs_modulus in (5500.0, 11000.0):
        probe = Probe(make_solver("fem", hybrid, youngs_modulus=youngs_modulus), radius=RADIUS, tolerance=1e-7)
        probe.press_static(centre(hybrid))
        forces.append(probe.force)
    # displacement-driven: the same geometry, twice the stiffness, twice the force (to the tolerance's effect)
    assert np.allclose(forces[1], 2.0 * forces[0], rtol=1e-3)


def test_deeper_presses_push_harder_and_touch_more(hybrid):
    solver = make_solver("fem", hybrid)
    probe = Probe(solver, radius=RADIUS)
    probe.press_static(centre(hybrid, depth=0.2e-3))
    shallow, shallow_contacts = probe.force[2], probe.contacts.size
    probe.press_static(centre(hybrid, depth=1.0e-3))
    # Hertz: F ∝ δ^1.5, so 5× deeper is 11× the force; the 1 mm mesh only blurs it (a = 0.9 and 2 mm)
    assert 8.0 < probe.force[2] / shallow < 15.0
    assert probe.contacts.size > shallow_contacts


def test_a_probe_and_a_pin_head_act_together_and_leave_each_other_alone(hybrid):
    solver = make_solver("fem", hybrid)
    pin = PinHead(solver, stiffness=1.0)
    far = np.array([0.012, 0.012, top(hybrid)])
    pin.grab(far)
    pin.drag(far + [0.0, 0.0, 0.002])
    probe = Probe(solver, radius=RADIUS)
    probe.press_static(centre(hybrid))
    pin_load = [load for load in solver.loads if load.node == pin.node]
    assert len(pin_load) == 1 and np.allclose(pin_load[0].force, [0.0, 0.0, 0.002])
    assert len(solver.loads) == 1 + probe.contacts.size
    probe.release()
    assert [load.node for load in solver.loads] == [pin.node] and probe.contacts.size == 0
    assert np.array_equal(probe.force, np.zeros(3))


def test_two_probes_share_the_surface(hybrid):
    solver = make_solver("fem", hybrid)
    left, right = Probe(solver, radius=RADIUS), Probe(solver, radius=RADIUS)
    left.move_to(centre(hybrid, x=-0.008))
    right.move_to(centre(hybrid, x=0.008))
    for _ in range(8):                    # the interactive path: one update each, then a step
        left.update()
        right.update()
        solver.step()
    assert set(left.contacts).isdisjoint(right.contacts)
    assert left.gaps().min() >= -2 * left.tolerance and right.gaps().min() >= -2 * right.tolerance
    # mirror images on a mirror-symmetric patch: the same push, within the mesh's asymmetry
    assert abs(left.force[2] - right.force[2]) <= 0.1 * right.force[2]


def test_a_capsule_lying_on_the_surface_presses_a_strip(hybrid):
    solver = make_solver("fem", hybrid)
    probe = Probe(solver, radius=RADIUS)
    start, end = centre(hybrid, x=-0.005), centre(hybrid, x=0.005)
    positions = probe.press_static(start, end)
    pressed = hybrid.surface.vertices[probe.contacts]
    assert np.ptp(pressed[:, 0]) > 2.5 * np.ptp(pressed[:, 1])     # a strip along the shaft
    along = np.clip(positions[:, 0], -0.005, 0.005)
    axis_points = np.stack([along, np.zeros_like(along), np.full_like(along, start[2])], axis=1)
    assert (np.linalg.norm(positions - axis_points, axis=1) - RADIUS).min() >= -probe.tolerance
    assert probe.force[2] > 0.0


def test_a_drag_at_constant_depth_is_smooth_and_never_tunnels(hybrid):
    solver = make_solver("fem", hybrid)
    probe = Probe(solver, radius=RADIUS)
    probe.press_static(centre(hybrid, x=-0.004))
    forces, deepest = [], 0.0
    for x in np.linspace(-0.004, 0.004, 81):       # 0.1 mm a frame, a tenth of an edge
        probe.move_to(centre(hybrid, x=x))
        solver.step()
        forces.append(probe.force[2])
        deepest = max(deepest, -probe.gaps().min())
    forces = np.array(forces)
    # no snag: no frame's force jumps by more than 5 % of the mean (the mesh's ripple at 1 mm edges is ±6 %)
    assert np.abs(np.diff(forces)).max() <= 0.05 * forces.mean()
    assert forces.min() >= 0.85 * forces.mean()
    # one update a frame lags the moving probe a little; it never tunnels (a tenth of the depth at most)
    assert deepest <= 0.1 * DEPTH


def test_a_drag_on_the_hybrid_solved_each_frame_is_smooth_and_stays_out(hybrid):
    """The simulator's and the scripts' path (Probe.settle each frame): the contact solved where the probe is."""
    solver = make_solver("hybrid", hybrid)
    probe = Probe(solver, radius=RADIUS)
    probe.press_static(centre(hybrid, x=-0.004))
    forces, deepest, settled = [], 0.0, 0
    for x in np.linspace(-0.004, 0.004, 81):
        settled += probe.settle(centre(hybrid, x=x))
        forces.append(probe.force[2])
        deepest = max(deepest, -probe.gaps().min())
    forces = np.array(forces)
    assert settled == 81                                   # every frame's contact converged within its iterations
    assert np.abs(np.diff(forces)).max() <= 0.05 * forces.mean()
    assert deepest <= 0.01 * DEPTH


def test_a_held_probe_settles_on_a_dynamic_method(hybrid):
    solver = make_solver("hybrid", hybrid)
    probe = Probe(solver, radius=RADIUS)
    probe.move_to(centre(hybrid))
    for _ in range(150):
        probe.update()
        solver.step()
    reference = Probe(make_solver("hybrid", hybrid), radius=RADIUS)
    reference.press_static(centre(hybrid))
    assert -probe.gaps().min() <= 2 * probe.tolerance
    assert np.linalg.norm(probe.force - reference.force) <= 0.02 * np.linalg.norm(reference.force)


def test_a_probe_smaller_than_the_triangles_is_refused_and_changes_nothing(hybrid):
    solver = make_solver("fem", hybrid)
    probe = Probe(solver, radius=0.5e-3)          # the 1 mm triangles' circumradius is about 0.6 mm
    with pytest.raises(SolverError, match="no larger than the surface's triangles"):
        probe.move_to([0.0, 0.0, top(hybrid)])
    assert probe.center is None and len(solver.loads) == 0


def test_a_probe_barely_larger_than_the_triangles_warns(hybrid):
    probe = Probe(make_solver("fem", hybrid), radius=1.2e-3)
    with pytest.warns(TissuesimWarning, match="sink"):
        probe.move_to([0.0, 0.0, top(hybrid) + 1.2e-3])


def test_the_probe_refuses_the_fixed_region_and_bad_points(hybrid):
    solver = make_solver("fem", hybrid)
    probe = Probe(solver, radius=RADIUS)
    with pytest.raises(BoundaryConditionError, match="fixed region"):
        probe.move_to([0.0, 0.0, 0.0])             # the bottom is fixed
    for bad in ([0.0, 0.0], [0.0, np.nan, 0.0], "here"):
        with pytest.raises(SolverError, match="centre"):
            probe.move_to(bad)
    with pytest.raises(SolverError, match="capsule end"):
        probe.move_to([0.0, 0.0, 0.03], [1.0])
    with pytest.raises(SolverError, match="radius"):
        Probe(solver, radius=-1.0)
    with pytest.raises(SolverError, match="not placed"):
        probe.update()
    assert probe.center is None and len(solver.loads) == 0


def test_a_reset_elsewhere_withdraws_the_probe_loads(hybrid):
    solver = make_solver("fem", hybrid)
    probe = Probe(solver, radius=RADIUS)
    probe.press_static(centre(hybrid))
    solver.reset()
    assert probe.contacts.size == 0 and np.array_equal(probe.force, np.zeros(3))
    probe.update()                                  # presses again from rest
    assert probe.contacts.size > 0


def test_a_finite_strain_press_converges_and_agrees_with_linear_at_small_depth(hybrid):
    forces = []
    for material in ("linear", "neo-hookean"):
        probe = Probe(make_solver("fem", hybrid, material=material), radius=RADIUS)
        probe.press_static(centre(hybrid))
        assert probe.gaps().min() >= -probe.tolerance
        forces.append(probe.force[2])
    # δ/R = 0.125: the contact strain is small and the two materials agree to a few per cent (measured 1.9 %)
    assert abs(forces[1] / forces[0] - 1.0) <= 0.05
