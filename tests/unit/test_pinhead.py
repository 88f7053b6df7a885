"""PinHead (§8.2, eq 24): snapping, the force law, release; headless and the same for every method."""

import numpy as np
import pytest

from tissuesim import HybridMesh, PinHead, SolverError, make_solver
from tissuesim.mesh import models
from tissuesim.solvers import available_solvers


@pytest.fixture(scope="module")
def hybrid():
    return HybridMesh.build(models.sphere(resolution=200))


@pytest.mark.parametrize("method", available_solvers())
def test_grab_drag_release_drives_any_solver(hybrid, method):
    solver = make_solver(method, hybrid)
    pin = PinHead(solver, stiffness=20.0)
    top = int(np.argmax(hybrid.surface.vertices[:, 2]))
    cursor = hybrid.surface.vertices[top] + [1e-4, 0.0, 1e-4]
    assert pin.grab(cursor) == top and pin.grabbed
    assert solver.load is None  # grabbing alone applies no force: x0 is the cursor itself
    force = pin.drag(cursor + [0.0, 0.0, 0.01])
    assert np.allclose(force, [0.0, 0.0, 0.2])  # f = k (x − x0), eq 24
    node, applied = solver.load
    assert node == top and np.array_equal(applied, force)  # exact: the load stores the force it was given
    for _ in range(5):
        solver.step()
    assert solver.positions[top, 2] > hybrid.surface.vertices[top, 2]
    pin.release()
    assert solver.load is None and not pin.grabbed


def test_grab_snaps_to_the_nearest_node_at_current_positions(hybrid):
    solver = make_solver("pbd", hybrid)
    v = hybrid.surface.vertices
    node = 17
    solver.state.positions[node] += [0.0, 0.0, 0.004]  # moved: the snap uses where the node is now
    pin = PinHead(solver, stiffness=1.0, snap_radius=0.01)
    assert pin.grab(v[node] + [0.0, 0.0, 0.004]) == node


def test_grab_far_from_the_surface_is_refused(hybrid):
    pin = PinHead(make_solver("pbd", hybrid), stiffness=1.0)
    with pytest.raises(SolverError, match="nothing to grab.*snap radius"):
        pin.grab([1.0, 1.0, 1.0])
    assert not pin.grabbed


def test_drag_without_grab_and_bad_arguments_are_refused(hybrid):
    solver = make_solver("pbd", hybrid)
    with pytest.raises(SolverError, match="grab"):
        PinHead(solver, stiffness=1.0).drag([0.0, 0.0, 0.0])
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(SolverError, match="stiffness"):
            PinHead(solver, stiffness=bad)
    with pytest.raises(SolverError, match="solver"):
        PinHead(hybrid, stiffness=1.0)
    with pytest.raises(SolverError, match="3 finite coordinates"):
        PinHead(solver, stiffness=1.0).grab([0.0, np.nan, 0.0])


def test_contact_radius_spreads_the_drag_force_over_the_patch(hybrid):
    solver = make_solver("embedded", hybrid)
    pin = PinHead(solver, stiffness=10.0, radius=0.012)
    top_node = int(np.argmax(hybrid.surface.vertices[:, 2]))
    cursor = solver.positions[top_node].copy()
    pin.grab(cursor)
    pin.drag(cursor + [0.0, 0.0, 0.01])
    assert solver.load_nodes.size > 1 and solver.load_nodes[0] == top_node
    np.testing.assert_allclose(solver.forces.sum(axis=0), [0.0, 0.0, 0.1], atol=1e-12)
    np.testing.assert_allclose(solver.load_shares.sum(), 1.0)


def test_contact_radius_reaching_the_support_is_refused_at_grab(hybrid):
    solver = make_solver("embedded", hybrid)
    pin = PinHead(solver, stiffness=10.0, radius=1.0)
    with pytest.raises(SolverError, match="fixed region"):
        pin.grab(solver.positions[int(np.argmax(solver.positions[:, 2]))])
