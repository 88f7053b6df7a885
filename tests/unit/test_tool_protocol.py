"""Every instrument keeps the :class:`~tissuesim.tools.base.Tool` protocol: made by kind, pressed, moved and
released, and its force on the tissue with one sign (along the way it moves the tissue) whatever its own ``force``
reports; a tool registered from outside the package joins the kinds."""

import numpy as np
import pytest

import tissuesim
from tissuesim.mesh import models
from tissuesim.tools.base import Tool, register_tool, tool_class, tool_kinds, unregister_tool

UP = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def sphere():
    return tissuesim.HybridMesh.build(models.sphere(resolution=386), fine_volume=False)


def top_of(solver):
    node = int(np.argmax(solver.rest_positions[:, 2]))
    return node, solver.rest_positions[node].copy()


@pytest.mark.parametrize("kind", tool_kinds())
def test_each_kind_is_a_tool_of_that_kind(kind):
    cls = tool_class(kind)
    assert issubclass(cls, Tool) and cls.kind == kind and cls.needs


def test_a_pin_head_pulled_up_pulls_the_tissue_up(sphere):
    solver = tissuesim.make_solver("hybrid", sphere)
    node, top = top_of(solver)
    pin = tool_class("pin-head")(solver, stiffness=20.0)
    assert not pin.engaged and pin.force_on_tissue is None
    pin.press(top)
    pin.move(top + 0.005 * UP)
    assert pin.engaged and pin.force_on_tissue == pytest.approx(20.0 * 0.005 * UP, abs=1e-15)
    pin.release()
    assert not pin.engaged and pin.force_on_tissue is None


def test_a_grasper_lifting_and_a_probe_pressing_push_the_tissue_the_way_it_moves(sphere):
    solver = tissuesim.make_solver("hybrid", sphere)
    node, top = top_of(solver)
    grasper = tool_class("grasper")(solver, radius=0.004)
    grasper.press(top)
    grasper.move(top + 5e-4 * UP)
    lifted = solver.positions[node, 2] - top[2]
    assert lifted > 0.0 and grasper.force_on_tissue[2] > 0.0
    assert np.array_equal(grasper.force_on_tissue, -grasper.force)          # the reaction on the jaws, opposite
    grasper.release()
    solver.reset()
    probe = tool_class("probe")(solver, radius=0.025)
    probe.press(top + (0.025 - 2e-4) * UP)
    assert probe.engaged and solver.positions[node, 2] < top[2] and probe.force_on_tissue[2] < 0.0
    probe.release()
    assert not probe.engaged and probe.force_on_tissue is None


def test_a_scalpel_puts_no_force_and_is_engaged_while_pressed(sphere):
    solver = tissuesim.make_solver("pbd", sphere)
    node, top = top_of(solver)
    scalpel = tool_class("scalpel")(solver, depth=0.005)
    scalpel.press(top)
    assert scalpel.engaged and scalpel.force_on_tissue is None
    scalpel.release()
    assert not scalpel.engaged


class Magnet(Tool):
    """A tool of one's own: a constant pull on the vertex nearest where it is pressed."""

    needs = "loads on surface vertices"

    def __init__(self, solver, *, pull: float):
        self.solver, self.pull, self.node = solver, pull, None

    def press(self, point):
        self.node = int(np.argmin(np.linalg.norm(self.solver.positions - point, axis=1)))
        self.load = self.solver.add_load(self.node, self.pull * UP)

    def move(self, point):
        pass        # a magnet pulls where it was put

    def release(self):
        self.solver.remove_load(self.load)
        self.node = None

    @property
    def engaged(self):
        return self.node is not None

    @property
    def force_on_tissue(self):
        return self.pull * UP if self.engaged else None


def test_a_tool_registered_outside_the_package_joins_the_kinds(sphere):
    register_tool("magnet")(Magnet)
    try:
        assert "magnet" in tool_kinds() and tool_class("magnet") is Magnet and Magnet.kind == "magnet"
        solver = tissuesim.make_solver("embedded", sphere)
        node, top = top_of(solver)
        magnet = tool_class("magnet")(solver, pull=0.2)
        magnet.press(top)
        solver.step()
        assert magnet.engaged and solver.positions[node, 2] > top[2]
    finally:
        unregister_tool("magnet")
    assert "magnet" not in tool_kinds()


def test_an_unknown_kind_is_refused_with_the_kinds():
    with pytest.raises(tissuesim.SolverError, match="pin-head, probe, grasper, scalpel"):
        tool_class("forceps")


def test_a_moved_capsule_keeps_its_shaft_and_a_probe_not_placed_is_not_moved(sphere):
    solver = tissuesim.make_solver("embedded", sphere)
    node, top = top_of(solver)
    probe = tool_class("probe")(solver, radius=0.025)
    with pytest.raises(tissuesim.SolverError, match="not placed"):
        probe.move(top)
    center = top + (0.025 - 2e-4) * UP
    probe.settle(center, center + [0.01, 0.0, 0.0])
    probe.move(center + [0.0, 0.002, 0.0])
    assert probe.end - probe.center == pytest.approx([0.01, 0.0, 0.0], abs=1e-15)
    probe.release()
