"""Scripted tools: a scene's pin-heads, probes and scalpel follow their keyframed paths, step by step.

A path is a list of keyframes (time [s], position [m], pressed). Choices where a path leaves room:

* between two keyframes the tool moves on the straight line between their positions, at constant speed;
* ``pressed`` holds from its keyframe until the next one: a tool pressed at keyframe i acts all the way to
  keyframe i + 1 (a pin-head drags, a probe pushes, a scalpel cuts), and is lifted at the first keyframe that is
  not pressed, where it is; it presses again at the next pressed keyframe;
* before its first keyframe a tool is not in play; after its last one it stays as that keyframe left it;
* a pin-head grabs the node nearest its position when pressed (within its snap radius); a scalpel presses there
  (within its depth of the surface); a probe is put there.
"""

from __future__ import annotations

import numpy as np

from ..errors import SolverError
from .load import SceneError, SceneFile


class ScriptedTool:
    """One of the scene's tools on a solver, following its path.

    Attributes:
        name: the tool's name (its kind and index where the scene gives none).
        kind: ``"pin-head"``, ``"probe"`` or ``"scalpel"``.
        tool: the library's tool (:class:`tissuesim.PinHead`, :class:`tissuesim.probe.Probe`,
            :class:`tissuesim.Scalpel`).
        pressed: whether it acts now.
    """

    def __init__(self, spec, tool, *, name: str):
        self.spec, self.tool, self.name, self.kind = spec, tool, name, spec.kind
        self.pressed = False
        self._times = np.array([key.time for key in spec.path], dtype=np.float64)
        self._positions = np.array([key.position for key in spec.path], dtype=np.float64).reshape(-1, 3)
        self._pressed = [key.pressed for key in spec.path]
        self._shaft = None if getattr(spec, "shaft", None) is None else np.asarray(spec.shaft, dtype=np.float64)
        self._position = None      # where the tool was last put [m]

    def target(self, time: float) -> tuple[bool, np.ndarray | None]:
        """Whether the path has the tool pressed at ``time`` [s], and where ``(3,) float64`` [m] (None before the
        first keyframe)."""
        if len(self._times) == 0 or time < self._times[0]:
            return False, None
        i = int(np.searchsorted(self._times, time, side="right")) - 1
        if i + 1 >= len(self._times):
            return self._pressed[i], self._positions[i].copy()
        w = (time - self._times[i]) / (self._times[i + 1] - self._times[i])
        return self._pressed[i], (1.0 - w) * self._positions[i] + w * self._positions[i + 1]

    def update(self, time: float) -> None:
        """Put the tool where its path has it at ``time`` [s]: press, move or lift."""
        pressed, position = self.target(time)
        if position is None:
            return
        try:
            if pressed and not self.pressed:
                self._press(position)
            elif pressed:
                self._move(position)
            elif self.pressed:
                self.tool.release()
        except SolverError as error:
            raise SceneError(f"{self.name} at t = {time:.4g} s, position {np.round(position, 6).tolist()} m: "
                             f"{error}") from None
        self.pressed, self._position = pressed, position

    def _press(self, position: np.ndarray) -> None:
        if self.kind == "pin-head":
            self.tool.grab(position)
            self.tool.drag(position)
        elif self.kind == "scalpel":
            self.tool.press(position)
        else:
            self._move(position)

    def _move(self, position: np.ndarray) -> None:
        if self.kind == "pin-head":
            self.tool.drag(position)
        elif self.kind == "scalpel":
            self.tool.move(position)
        else:   # the contact solved where the probe is now (a frame's iterations), as the simulator does
            self.tool.settle(position, None if self._shaft is None else position + self._shaft)

    @property
    def position(self) -> np.ndarray | None:
        """``(3,) float64`` where the tool was last put [m], or None before its first keyframe."""
        return self._position

    @property
    def force(self) -> np.ndarray | None:
        """``(3,) float64`` the force [N] the tool puts on the tissue now, or None (a scalpel, or not pressed)."""
        if not self.pressed or self.kind == "scalpel":
            return None
        if self.kind == "pin-head":
            return self.tool.force(self._position)
        return -np.asarray(self.tool.force, dtype=np.float64)     # the probe reports the force on itself


def acting(tools: list[ScriptedTool], positions: np.ndarray) -> tuple[list, list, float]:
    """What ``tools`` do now, to draw or record: ``(pin_heads, probes, blade_depth)``, each pulling pin-head as
    (its vertex's position (3,), its cursor (3,)) [m] over the surface ``positions`` ``(n, 3)`` [m], each pressing
    probe as (centre (3,), radius) [m], and the scalpel's depth [m] (0 without one)."""
    pins = [(positions[tool.tool.node], tool.position) for tool in tools
            if tool.kind == "pin-head" and tool.pressed and tool.tool.grabbed]
    probes = [(tool.tool.center, tool.tool.radius) for tool in tools
              if tool.kind == "probe" and tool.pressed and tool.tool.center is not None]
    depth = max((tool.tool.depth for tool in tools if tool.kind == "scalpel"), default=0.0)
    return pins, probes, float(depth)


def make_tools(loaded: SceneFile, solver) -> list[ScriptedTool]:
    """The scene's tools on ``solver``, in the scene's order; SceneError where the library refuses one (a
    blade longer than the model, a method that cannot be cut) or where a kind is not in this version."""
    tools = []
    for i, spec in enumerate(loaded.scene.tools):
        name = spec.name or f"{spec.kind} {i}"
        try:
            tools.append(ScriptedTool(spec, _library_tool(spec, solver), name=name))
        except SolverError as error:
            raise SceneError(f"{loaded.path.name}: tools[{i}] ({name}): {error}") from None
    return tools


def _library_tool(spec, solver):
    if spec.kind == "pin-head":
        from ..interaction import PinHead

        return PinHead(solver, stiffness=spec.stiffness, radius=spec.radius)
    if spec.kind == "scalpel":
        from ..scalpel import Scalpel

        return Scalpel(solver, depth=spec.depth) if spec.depth is not None else Scalpel(solver)
    from ..probe import Probe

    return Probe(solver, radius=spec.radius)
