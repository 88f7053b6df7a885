"""A scene's scripted tools played in the simulator (``tissuesim view scene.toml``), until the user takes over.

The scene's pin-heads, probes, graspers and scalpel follow their keyframed paths (:mod:`tissuesim.scene.script`) in
simulated time, one update before each step, exactly as ``tissuesim run`` plays them. The window's space key pauses
the simulation, and with it the script; :meth:`ScenePlayback.restart` plays it again from the start on the body at
rest. A press of the user's own tool on the tissue takes over: the scripted tools let go and the scene stops playing
(the body stays as the script left it). A change of method or material builds a new solver: the script's tools are
made anew on it and go on from the time reached.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..scene.load import SceneFile
    from ..solvers.base import Solver


class ScenePlayback:
    """The script of a scene file in the simulator (see the module docstring).

    Args:
        loaded: the :class:`~tissuesim.scene.load.SceneFile`.

    Attributes:
        time: the script's simulated time [s]. end: its last keyframe [s]. scripted: whether it has a tool with a
        path. playing: whether its tools act.
        tools: the :class:`~tissuesim.scene.script.ScriptedTool` list on the solver they were made for.
    """

    def __init__(self, loaded: SceneFile):
        self.loaded = loaded
        keys = [key.time for tool in loaded.scene.tools for key in tool.path]
        self.end = float(max(keys)) if keys else 0.0
        self.scripted = bool(keys)
        self.time = 0.0
        self.playing = self.scripted
        self.tools = []
        self._solver = None

    def before_step(self, solver: Solver, dt: float) -> None:
        """Put the tools where the script has them now on ``solver`` (made anew on a new solver), then count
        ``dt`` [s] of script time."""
        if not self.playing:
            return
        if solver is not self._solver:
            from ..scene.script import make_tools

            self.tools, self._solver = make_tools(self.loaded, solver), solver
        for tool in self.tools:
            tool.update(self.time)
        self.time += dt

    def take_over(self) -> bool:
        """The user's tool takes over: the scripted tools let go, the script stops; whether it was playing."""
        was = self.playing
        for tool in self.tools:
            if tool.pressed:
                tool.tool.release()
        self.tools, self._solver, self.playing = [], None, False
        return was

    def restart(self) -> None:
        """Play the script again from its start (the caller resets the body to rest)."""
        self.take_over()
        self.time, self.playing = 0.0, self.scripted

    def acting(self, positions: np.ndarray) -> tuple[list, list, float]:
        """The scripted tools acting now over the surface ``positions`` ``(n, 3)`` [m], to draw and record
        (:func:`tissuesim.scene.script.acting`: pin-heads, probes, the scalpel's depth; the graspers are
        :meth:`graspers`)."""
        from ..scene.script import acting

        return acting(self.tools, positions)[:3]

    def graspers(self) -> list:
        """The scripted graspers holding now, each as (its jaws' position ``(3,) float64``, their reach) [m]: the
        ``graspers`` of :func:`tissuesim.recording.tools_of`."""
        from ..scene.script import grasping

        return grasping(self.tools)

    def status(self) -> str:
        """A line for the panel."""
        if not self.scripted:
            return "scene: no scripted tools"
        if not self.playing:
            return "scene: stopped (you took over); R plays it again"
        state = (f"playing, t = {self.time:.2f} of {self.end:.2f} s" if self.time <= self.end else
                 f"played to its end ({self.end:.2f} s)")
        forces = "".join(f", {tool.name} {np.linalg.norm(tool.force):.2f} N" for tool in self.tools
                         if tool.force is not None)
        return f"scene: {state}{forces}; a press on the tissue takes over"
