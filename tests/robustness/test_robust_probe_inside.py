"""N5, N26: a frictionless probe pushes each vertex away from its core, so it presses the body only from outside. A
probe inside the body felt nothing (force 0, every gap positive), one enclosing it pushed everything outward, and a
probe pressed deeper than its radius "converged" mirrored: the vertices above its centre pushed up, the force on the
probe pointing down. Each is refused, saying why, and changes nothing."""

import numpy as np
import pytest

from tissuesim import SolverError, make_solver
from tissuesim.cli import main
from tissuesim.tools.probe import Probe
from tissuesim.solvers import available_solvers

METHODS = available_solvers()
RADIUS = 0.012      # [m] larger than the small cube's triangles
TOP = 0.08          # [m] the small cube's top; its centre is (0, 0, 0.04)


def held(small_cube, method):
    """A solver with a load acting and stepped away from rest, and a probe not yet placed."""
    solver = make_solver(method, small_cube)
    solver.add_load(int(np.argmax(solver.rest_positions[:, 2])), [0.0, 0.0, 0.05])
    for _ in range(2):
        solver.step()
    return solver, Probe(solver, radius=RADIUS)


def record(solver, probe):
    return (solver.positions.copy(), solver.velocities.copy(), solver.forces.copy(), len(solver.loads),
            probe.center, probe.contacts.size)


def assert_unchanged(solver, probe, before):
    positions, velocities, forces, loads, center, contacts = before
    assert np.array_equal(solver.positions, positions) and np.array_equal(solver.velocities, velocities)
    assert np.array_equal(solver.forces, forces) and len(solver.loads) == loads
    assert probe.center is center and probe.contacts.size == contacts


@pytest.mark.parametrize("method", METHODS)
def test_a_probe_inside_the_body_is_refused_by_every_entry_point(small_cube, method):
    solver, probe = held(small_cube, method)
    before = record(solver, probe)
    for call in (probe.press_static, probe.move_to, probe.settle):
        with pytest.raises(SolverError, match=r"centre lies inside the body.*put it outside the surface"):
            call([0.0, 0.0, 0.04])
        assert_unchanged(solver, probe, before)


def test_a_capsule_through_the_body_is_refused(small_cube):
    solver, probe = held(small_cube, "fem")
    # both ends outside, the shaft through the cube
    with pytest.raises(SolverError, match=r"core \(the segment .*\) lies inside the body"):
        probe.move_to([-0.1, 0.0, 0.04], end=[0.1, 0.0, 0.04])


def test_a_probe_enclosing_the_body_is_refused(small_cube):
    solver, probe = held(small_cube, "hybrid")
    probe = Probe(solver, radius=0.2)
    with pytest.raises(SolverError, match=r"encloses the whole body: all 386 surface vertices lie inside it"):
        probe.press_static([0.0, 0.0, 0.04])


@pytest.mark.parametrize("method", METHODS)
def test_a_press_deeper_than_the_radius_is_refused_not_mirrored(small_cube, method):
    solver, probe = held(small_cube, method)
    before = record(solver, probe)
    # 1.5 R deep: the centre 6 mm below the top; it used to converge with the top node 6 mm above it, pulled
    with pytest.raises(SolverError, match=r"centre lies inside the body.*cannot pull"):
        probe.press_static([0.0, 0.0, TOP + RADIUS - 1.5 * RADIUS])
    assert_unchanged(solver, probe, before)


def test_a_press_that_carries_the_surface_over_the_centre_is_refused(small_cube):
    # from a press 0.9 R deep, the centre in the dimple (outside the body), on to 1.3 R: fem's iterations carried
    # the surface over the centre and converged mirrored (the force on the probe pointing down)
    solver = make_solver("fem", small_cube)
    probe = Probe(solver, radius=RADIUS)
    for depth in (0.5, 0.9):
        probe.press_static([0.0, 0.0, TOP + RADIUS - depth * RADIUS])
    before = record(solver, probe)
    force = probe.force
    with pytest.raises(SolverError, match=r"surface passed over the probe's centre while pressing"):
        probe.press_static([0.0, 0.0, TOP + RADIUS - 1.3 * RADIUS])
    assert_unchanged(solver, probe, before)
    assert np.array_equal(probe.force, force) and force[2] > 0.0


def test_a_scene_with_the_probe_inside_stops_with_one_line(tmp_path, capsys):
    scene = tmp_path / "inside.toml"
    scene.write_text('[model]\nname = "cube"\nresolution = 386\n[[tools]]\nkind = "probe"\nradius = 0.012\n'
                     'path = [{ time = 0.0, position = [0.0, 0.0, 0.04] }]\n[run]\nduration = 0.02\n')
    assert main(["run", str(scene)]) != 0
    err = capsys.readouterr().err
    # the progress of the build, then the refusal as the one last line
    assert "inside the body" in err.strip().splitlines()[-1] and "Traceback" not in err
