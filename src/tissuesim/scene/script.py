"""Scripted tools: a scene's pin-heads, probes, graspers and scalpel follow their keyframed paths, step by step.

A path is a list of keyframes (time [s], position [m], pressed; a grasper's also its orientation). Choices where a
path leaves room:

* between two keyframes the tool moves on the straight line between their positions, at constant speed, and a
  grasper's jaws turn about one axis at constant angular speed (from one orientation to the next the shortest way);
* ``pressed`` holds from its keyframe until the next one: a tool pressed at keyframe i acts all the way to
  keyframe i + 1 (a pin-head drags, a probe pushes, a grasper holds, a scalpel cuts), and is lifted at the first
  keyframe that is not pressed, where it is; it presses again at the next pressed keyframe;
* before its first keyframe a tool is not in play; after its last one it stays as that keyframe left it;
* a pin-head grabs the node nearest its position when pressed (within its snap radius); a scalpel presses there
  (within its depth of the surface); a probe is put there; a grasper's jaws close there, on the surface vertices
  within their radius, at the orientation the path has then (its rotations are about the jaws from that grab);
* each update carries a grasper's jaws to the path's pose at static equilibrium (``Grasper.move_to``, to its
  tolerance): the held vertices are where the path puts them whatever dt, so a run's answer does not depend on it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..errors import BoundaryConditionError, SolverError
from .load import SceneError, SceneFile

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

    from ..tools.grasper import Grasper
    from ..tools.pinhead import PinHead
    from ..tools.probe import Probe
    from ..tools.scalpel import Scalpel
    from ..solvers.base import Solver
    from .schema import ToolSpec


class ScriptedTool:
    """One of the scene's tools on a solver, following its path.

    Attributes:
        name: the tool's name (its kind and index where the scene gives none).
        kind: ``"pin-head"``, ``"probe"``, ``"grasper"`` or ``"scalpel"``.
        tool: the library's tool (:class:`tissuesim.PinHead`, :class:`tissuesim.tools.probe.Probe`,
            :class:`tissuesim.Grasper`, :class:`tissuesim.Scalpel`).
        pressed: whether it acts now.
    """

    def __init__(self, spec: ToolSpec, tool: PinHead | Probe | Grasper | Scalpel, *, name: str):
        self.spec, self.tool, self.name, self.kind = spec, tool, name, spec.kind
        self.pressed = False
        self._times = np.array([key.time for key in spec.path], dtype=np.float64)
        self._positions = np.array([key.position for key in spec.path], dtype=np.float64).reshape(-1, 3)
        self._pressed = [key.pressed for key in spec.path]
        self._turns = _orientations(spec.path)
        self.shaft_offset = None if getattr(spec, "shaft", None) is None else np.asarray(spec.shaft, dtype=np.float64)
        self._position = None      # where the tool was last put [m]
        self.grip = None          # a grasper's orientation at its grab (a scipy Rotation)

    def target(self, time: float) -> tuple[bool, np.ndarray | None]:
        """Whether the path has the tool pressed at ``time`` [s], and where ``(3,) float64`` [m] (None before the
        first keyframe)."""
        i, w = self._segment(time)
        if i < 0:
            return False, None
        if w == 0.0:
            return self._pressed[i], self._positions[i].copy()
        return self._pressed[i], (1.0 - w) * self._positions[i] + w * self._positions[i + 1]

    def orientation(self, time: float) -> Rotation:
        """The orientation the path gives the tool at ``time`` [s] (a ``scipy.spatial.transform.Rotation``; the
        first keyframe's before it): the shortest turn between two keyframes' orientations, at constant speed."""
        i, w = self._segment(time)
        i = max(i, 0)
        if w == 0.0:
            return self._turns[i]
        step = (self._turns[i].inv() * self._turns[i + 1]).as_rotvec()
        return self._turns[i] * type(self._turns[i]).from_rotvec(w * step)

    def _segment(self, time: float) -> tuple[int, float]:
        """The keyframe i at or before ``time`` [s] (-1 before the first) and the fraction w of the way to the next
        (0 after the last)."""
        if len(self._times) == 0 or time < self._times[0]:
            return -1, 0.0
        i = int(np.searchsorted(self._times, time, side="right")) - 1
        if i + 1 >= len(self._times):
            return i, 0.0
        return i, float((time - self._times[i]) / (self._times[i + 1] - self._times[i]))

    def update(self, time: float) -> None:
        """Put the tool where its path has it at ``time`` [s]: press, move or lift."""
        pressed, position = self.target(time)
        if position is None:
            return
        behaviour = KINDS[self.kind]
        try:
            if pressed and not self.pressed:
                behaviour.press(self, position, time)
            elif pressed:
                behaviour.move(self, position, time)
            elif self.pressed:
                self.tool.release()
        except (SolverError, BoundaryConditionError) as error:
            raise SceneError(f"{self.name} at t = {time:.4g} s, position {np.round(position, 6).tolist()} m: "
                             f"{error}") from None
        self.pressed, self._position = pressed, position

    @property
    def position(self) -> np.ndarray | None:
        """``(3,) float64`` where the tool was last put [m], or None before its first keyframe."""
        return self._position

    @property
    def force(self) -> np.ndarray | None:
        """``(3,) float64`` the force [N] the tool puts on the tissue now (:attr:`~tissuesim.tools.base.Tool.
        force_on_tissue`), or None (a scalpel, or not pressed)."""
        return self.tool.force_on_tissue if self.pressed else None


def _orientations(path) -> list:
    """Each keyframe's orientation (scipy Rotations): its rotation vector [rad], else the keyframe before's, the
    first's none (a tool whose keyframes have no rotation stays unturned)."""
    from scipy.spatial.transform import Rotation

    turns, vector = [], np.zeros(3)
    for key in path:
        if getattr(key, "rotation", None) is not None:
            vector = np.asarray(key.rotation, dtype=np.float64)
        turns.append(Rotation.from_rotvec(vector))
    return turns or [Rotation.identity()]


# ------------------------------------------------------------------------------------------- what each kind does
@dataclass(frozen=True)
class Kind:
    """How a scripted tool of one kind is made and driven.

    Attributes:
        make: ``(spec, solver) -> tool``, the library's tool. press, move: ``(scripted, position (3,) [m], time
        [s])``, at the path's first pressed update and at each after (a scene's path gives a grasper's turn and a
        probe's shaft, and carries a grasper to static equilibrium, which the tools' own press and move do not).
    """

    make: Callable
    press: Callable
    move: Callable


def _make_pin_head(spec, solver):
    from ..tools.pinhead import PinHead

    return PinHead(solver, stiffness=spec.stiffness, radius=spec.radius)


def _grab_and_drag(scripted: ScriptedTool, position: np.ndarray, time: float) -> None:
    scripted.tool.grab(position)
    scripted.tool.drag(position)


def _make_probe(spec, solver):
    from ..tools.probe import Probe

    return Probe(solver, radius=spec.radius)


def _put_probe(scripted: ScriptedTool, position: np.ndarray, time: float) -> None:
    # the contact solved where the probe is now (a frame's iterations), as the simulator does
    shaft = None if scripted.shaft_offset is None else position + scripted.shaft_offset
    scripted.tool.settle(position, shaft)


def _make_grasper(spec, solver):
    from ..tools.grasper import Grasper

    return Grasper(solver, radius=spec.radius, tolerance=spec.tolerance)


def _grasp(scripted: ScriptedTool, position: np.ndarray, time: float) -> None:
    scripted.tool.grab(position)
    scripted.grip = scripted.orientation(time)
    _carry(scripted, position, time)


def _carry(scripted: ScriptedTool, position: np.ndarray, time: float) -> None:
    # the jaws' turn since the grab, about the jaws: their orientation now times the grab's inverse
    turn = (scripted.orientation(time) * scripted.grip.inv()).as_matrix()
    scripted.tool.move_to(position, turn)


def _make_scalpel(spec, solver):
    from ..tools.scalpel import Scalpel

    return Scalpel(solver, depth=spec.depth) if spec.depth is not None else Scalpel(solver)


KINDS = {
    "pin-head": Kind(_make_pin_head, _grab_and_drag, lambda s, position, time: s.tool.drag(position)),
    "probe": Kind(_make_probe, _put_probe, _put_probe),
    "grasper": Kind(_make_grasper, _grasp, _carry),
    "scalpel": Kind(_make_scalpel, lambda s, position, time: s.tool.press(position),
                    lambda s, position, time: s.tool.move(position)),
}


def acting(tools: list[ScriptedTool], positions: np.ndarray) -> tuple[list, list, float, list]:
    """What ``tools`` do now, to draw or record: ``(pin_heads, probes, blade_depth, graspers)``, each pulling
    pin-head as (its vertex's position (3,), its cursor (3,)) [m] over the surface ``positions`` ``(n, 3)`` [m],
    each pressing probe as (centre (3,), radius) [m], the scalpel's depth [m] (0 without one), and each holding
    grasper as (its jaws' position (3,), their reach) [m] (the arguments of :func:`tissuesim.recording.tools_of`)."""
    pins = [(positions[tool.tool.node], tool.position) for tool in tools
            if tool.kind == "pin-head" and tool.pressed and tool.tool.grabbed]
    probes = [(tool.tool.center, tool.tool.radius) for tool in tools
              if tool.kind == "probe" and tool.pressed and tool.tool.center is not None]
    depth = max((tool.tool.depth for tool in tools if tool.kind == "scalpel"), default=0.0)
    return pins, probes, float(depth), grasping(tools)


def grasping(tools: list[ScriptedTool]) -> list:
    """Each of ``tools`` that is a grasper holding now, as (its jaws' position ``(3,) float64``, their reach) [m]."""
    return [(tool.tool.position.copy(), tool.tool.radius) for tool in tools
            if tool.kind == "grasper" and tool.tool.holding]


def make_tools(loaded: SceneFile, solver: Solver) -> list[ScriptedTool]:
    """The scene's tools on ``solver``, in the scene's order; SceneError where the library refuses one (a
    blade longer than the model, a method that cannot be cut) or where a kind is not in this version."""
    tools = []
    for i, spec in enumerate(loaded.scene.tools):
        name = spec.name or f"{spec.kind} {i}"
        try:
            tools.append(ScriptedTool(spec, KINDS[spec.kind].make(spec, solver), name=name))
        except SolverError as error:
            raise SceneError(f"{loaded.path.name}: tools[{i}] ({name}): {error}") from None
    return tools
