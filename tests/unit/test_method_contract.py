"""The contract every registered method keeps, run over :func:`tissuesim.solvers.available_solvers` and over a
method registered here, outside the package (so a new method is checked the moment it is registered).

* its card: labels, colour and line style a plot can use, the linear material, free scalars that are its options;
* physics first (DESIGN): with the linear material the static answer scales as 1/E at fixed strain, does not move
  with dt or the density, and, where the method is linear in the load (its card says so), superposes;
* the load handles: loads added, moved and removed by handle, the forces their sum;
* a snapshot put back leaves the steps bit for bit a twin's;
* the tools: a pin-head drags it, a probe presses it, a grasper lifts it; the scalpel cuts the methods that cut.

Tolerances: static answers that are solved directly agree to 1e-8 of the largest displacement; a method whose static
solve steps to rest (the surface methods) agrees to 1e-4, its settling criterion's reach.
"""

import matplotlib.colors
import numpy as np
import pytest

import tissuesim
from tissuesim import Grasper, PinHead, Probe, Scalpel
from tissuesim.experiments import methods as shown
from tissuesim.experiments.protocol import load_node
from tissuesim.experiments.wound import incision_line
from tissuesim.mesh import models
from tissuesim.solvers import available_solvers, make_solver, method_names, register, solver_class, unregister
from tissuesim.solvers.embedded import EmbeddedSolver
from tissuesim.solvers.registry import solver_options

PLUG_IN = "plug-in-embedded"
RADIUS = 0.008           # m, the contact patch
FORCE = np.array([0.0, 0.0, -0.05])     # N: small, linear elasticity holds
DIRECT, STEPPED = 1e-8, 1e-4


class PlugInEmbedded(EmbeddedSolver):
    """A method of one's own, registered from outside the package: the embedded surface under its own card."""

    label = "embedded surface, a plug-in"
    short_label = "Plug."
    colour = "tab:cyan"
    line_style = "--"


METHODS = [*available_solvers(), PLUG_IN]


def card(method):
    """The class of a method, the plug-in's too while tests are collected (it is registered when they run)."""
    return PlugInEmbedded if method == PLUG_IN else solver_class(method)


@pytest.fixture(scope="module", autouse=True)
def plug_in():
    register(PLUG_IN)(PlugInEmbedded)
    yield
    unregister(PLUG_IN)


@pytest.fixture(scope="module")
def cube():
    return tissuesim.HybridMesh.build(models.cube(resolution=386), fine_volume=True)


@pytest.fixture(scope="module")
def sphere():
    """The tools' body: curved, so that springs on its surface carry a normal load from the start (on a flat patch
    a mass-spring surface answers a small press with no force)."""
    return tissuesim.HybridMesh.build(models.sphere(resolution=386), fine_volume=True)


@pytest.fixture(scope="module")
def node(cube):
    return load_node(cube.surface.vertices, cube.surface.triangles)


@pytest.fixture(scope="module")
def other(cube, node):
    """A free top node near the load node, 30th nearest."""
    rest = cube.surface.vertices
    return int(np.argsort(np.linalg.norm(rest - rest[node], axis=1))[30])


def displacement(solver, node, force=FORCE) -> np.ndarray:
    solver.reset()
    positions = np.array(solver.solve_static(node, force, radius=RADIUS))
    solver.reset()
    return positions - solver.rest_positions


def tolerance(method) -> float:
    return DIRECT if solver_class(method).solves_statics() else STEPPED


def agree(a, b, method) -> bool:
    return np.abs(a - b).max() <= tolerance(method) * np.abs(b).max()


def test_a_registered_method_joins_every_list():
    assert PLUG_IN in available_solvers() and PLUG_IN in method_names(cuts=True, material="neo-hookean")
    assert PLUG_IN in shown.protocol_methods() and PLUG_IN not in method_names(in_paper=True)
    assert (shown.short_label(PLUG_IN), shown.colour(PLUG_IN)) == ("Plug.", "tab:cyan")


@pytest.mark.parametrize("method", METHODS)
def test_the_card_is_complete(method):
    card = solver_class(method)
    assert card.name == method and "?" not in (card.label, card.short_label)
    assert matplotlib.colors.is_color_like(card.colour) and card.line_style in ("-", "--", "-.", ":")
    assert "linear" in card.materials
    options = solver_options(method)
    assert all(option in options for option, _, _ in card.free_scalars.values())
    assert all(0.0 < low < high for _, low, high in card.free_scalars.values())


@pytest.mark.parametrize("method", METHODS)
def test_the_static_answer_scales_as_one_over_e_and_ignores_dt_and_density(cube, node, method):
    base = displacement(make_solver(method, cube), node)
    assert np.abs(base).max() > 0.0
    stiffer = displacement(make_solver(method, cube, youngs_modulus=55000.0), node, 10.0 * FORCE)
    assert agree(stiffer, base, method)
    for options in ({"dt": 0.0025}, {"dt": 0.02}, {"density": 100.0}, {"density": 10000.0}):
        assert agree(displacement(make_solver(method, cube, **options), node), base, method), options


@pytest.mark.parametrize("method", [m for m in METHODS if card(m).linear_in_load])
def test_loads_superpose_where_the_method_is_linear(cube, node, other, method):
    solver = make_solver(method, cube)
    side = np.array([0.02, 0.0, 0.0])
    solver.reset()
    solver.add_load(node, FORCE, radius=RADIUS)
    solver.add_load(other, side, radius=RADIUS)
    together = np.array(solver.solve_static()) - solver.rest_positions
    apart = displacement(solver, node) + displacement(solver, other, side)
    assert agree(together, apart, method)


@pytest.mark.parametrize("method", METHODS)
def test_loads_are_added_moved_and_removed_by_handle(cube, node, other, method):
    solver = make_solver(method, cube)
    first = solver.add_load(node, FORCE, radius=RADIUS)
    second = solver.add_load(other, [0.01, 0.0, 0.0])
    solver.move_load(first, force=2.0 * FORCE)
    assert solver.forces.sum(axis=0) == pytest.approx(2.0 * FORCE + [0.01, 0.0, 0.0], abs=1e-15)
    solver.remove_load(second)
    assert solver.forces.sum(axis=0) == pytest.approx(2.0 * FORCE, abs=1e-15) and len(solver.loads) == 1
    solver.step()
    solver.reset()
    assert not solver.loads and np.array_equal(solver.positions, solver.rest_positions)


@pytest.mark.parametrize("method", METHODS)
def test_a_snapshot_put_back_steps_as_its_twin(cube, node, method):
    first, twin = make_solver(method, cube), make_solver(method, cube)
    for solver in (first, twin):
        solver.set_load(node, FORCE, radius=RADIUS)
        solver.step()
    snapshot = first.snapshot()
    first.solve_static(node, -FORCE, radius=RADIUS)
    first.restore(snapshot)
    for _ in range(3):
        first.step()
        twin.step()
    assert np.array_equal(first.positions, twin.positions)


@pytest.mark.parametrize("method", METHODS)
def test_the_tools_act_on_it(sphere, method):
    solver = make_solver(method, sphere)
    node = int(np.argmax(solver.rest_positions[:, 2]))
    top = solver.rest_positions[node]
    pin = PinHead(solver, stiffness=20.0)
    pin.grab(top)
    pin.drag(top + [0.0, 0.0, 0.005])
    for _ in range(3):
        solver.step()
    assert solver.positions[node, 2] > top[2]
    pin.release()
    solver.reset()
    probe = Probe(solver, radius=0.025)         # larger than the coarse cube's triangles can sink into it
    probe.press_static(top + [0.0, 0.0, 0.025 - 2e-4])
    assert probe.force[2] > 0.0 and solver.positions[node, 2] < top[2]
    probe.release()
    solver.reset()
    grasper = Grasper(solver, radius=0.003)
    grasper.grab(top)
    grasper.move_to(top + [0.0, 0.0, 5e-4])
    assert grasper.force[2] < 0.0 and solver.positions[node, 2] > top[2]
    grasper.release()


@pytest.mark.parametrize("method", method_names(cuts=True) + (PLUG_IN,))
def test_the_scalpel_cuts_the_methods_that_cut(cube, node, method):
    solver = make_solver(method, cube)
    before = solver.node_count
    start, end = incision_line(solver.rest_positions, length=0.02)
    scalpel = Scalpel(solver, depth=0.005)
    scalpel.press(start, direction=[0.0, 0.0, -1.0])
    for fraction in np.linspace(0.2, 1.0, 5):
        scalpel.move(start + fraction * (end - start))
    scalpel.release()
    assert solver.node_count > before and solver.hybrid.surface.vertex_count == solver.node_count
    solver.set_load(node, FORCE, radius=RADIUS)
    solver.step()
    assert np.all(np.isfinite(solver.positions))


def test_a_method_that_cannot_be_cut_is_refused_with_its_reason(cube):
    for method in method_names(cuts=False):
        with pytest.raises(tissuesim.SolverError, match=method):
            Scalpel(make_solver(method, cube), depth=0.005).press(
                cube.surface.vertices[0], direction=[0.0, 0.0, -1.0])
