"""What the device holds, the visual loop's side of it: a pin-head's tip (a force on one M_S node, spread over a
contact patch of radius R) or a grasper's jaws (the surface patch within R of a node, carried rigidly). Each
measures the local response x = x0 + C f that the servo loop's coupling is built on (:mod:`.response`), puts the
servo's force f into the solver, and lets go. Chosen by name: :data:`TOOLS`."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import SolverError
from ..tools.grasper import Grasper
from ..solvers.checks import is_integer
from ..solvers.load_set import ToolLoad
from ..solvers.snapshot import refusal_restores
from .response import LocalResponse, grasper_response, local_response

if TYPE_CHECKING:
    from ..solvers.base import Solver


class PinHeadTool:
    """The tip: f is the solver's load on the grabbed node, over the contact patch of ``radius`` [m] (None: the
    node alone), beside any other load."""

    grasper = None

    def __init__(self, solver: Solver, *, radius: float | None):
        self.solver, self.radius = solver, radius
        self._load = ToolLoad(solver)

    def take(self, node: int) -> LocalResponse:
        """Hold ``node``: its response at zero tool force, then the tool's previous load withdrawn. Refused as
        :func:`~.response.local_response` refuses, changing nothing."""
        response = local_response(self.solver, node, radius=self.radius)
        self._load.withdraw()
        return response

    def apply(self, response: LocalResponse, force: np.ndarray) -> None:
        """``force`` ``(3,)`` [N] the tool's load on the node."""
        self._load.apply(response.node, force, radius=self.radius)

    def respond(self, response: LocalResponse, force: np.ndarray) -> LocalResponse:
        """The node's response measured again around ``force`` ``(3,)`` [N]."""
        return local_response(self.solver, response.node, radius=self.radius, around=force)

    def release(self) -> None:
        self._load.withdraw()


class GrasperTool:
    """The jaws: a :class:`~tissuesim.Grasper` of reach ``radius`` [m] held at a node; f is the sum of its forces on
    the tissue, and the jaws go where the coupling puts them, x_j = x0 + C_g f (:func:`~.response.grasper_response`).
    The jaws are not turned: a device that reads a position renders a force, not a torque."""

    def __init__(self, solver: Solver, *, radius: float | None):
        if radius is None:
            raise SolverError("a grasper's jaws need a reach: pass radius= [m] (they hold the surface vertices within "
                              "it of the grabbed node)")
        self.grasper = Grasper(solver, radius=radius)

    def take(self, node: int) -> LocalResponse:
        """Put the jaws on ``node`` where it is (they hold the vertices within their reach, letting go of the patch
        held before) and measure their response there. Refused as :meth:`Grasper.grab` and
        :func:`~.response.grasper_response` refuse, changing nothing (the patch held before is kept)."""
        grasper = self.grasper
        count = grasper.solver.node_count
        if not is_integer(node) or not 0 <= int(node) < count:
            raise SolverError(f"the jaws' node {node!r} is not one of the surface's vertices 0..{count - 1}; pick an "
                              "M_S vertex index, or grab() where the tool is")
        with refusal_restores(grasper, solving=True):
            grasper.grab(grasper.solver.positions[int(node)])
            return grasper_response(grasper, node)

    def apply(self, response: LocalResponse, force: np.ndarray) -> None:
        """The jaws to where ``force`` ``(3,)`` [N] puts them, and a frame's worth of the grasper's iteration
        (:meth:`Grasper.settle`: the next call goes on where it stopped)."""
        self.grasper.settle(response.origin + response.compliance @ force)

    def respond(self, response: LocalResponse, force: np.ndarray) -> LocalResponse:
        """The jaws' response measured again where :meth:`apply` put them for ``force``."""
        return grasper_response(self.grasper, response.node)

    def release(self) -> None:
        self.grasper.release()


#: The tools a haptic loop's device can hold, by name.
TOOLS = {"pin-head": PinHeadTool, "grasper": GrasperTool}


def make_tool(name: str, solver: Solver, *, radius: float | None) -> PinHeadTool | GrasperTool:
    """The tool called ``name`` (:data:`TOOLS`) on ``solver``, of ``radius`` [m]."""
    if name not in TOOLS:
        raise SolverError(f"unknown haptic tool {name!r}; choose one of {', '.join(map(repr, TOOLS))}")
    return TOOLS[name](solver, radius=radius)
