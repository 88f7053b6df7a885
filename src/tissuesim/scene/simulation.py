"""A scene run headless: its solver and scripted tools stepped over the run's duration (``tissuesim run``).

Each step i takes the tools to where their paths have them at t_i = i·dt, then advances the solver by dt to
t_(i+1); a caller's ``on_step(time)`` sees the state at t_(i+1) (the command records it). What the run reports is a
:class:`RunSummary`.
"""

from __future__ import annotations

import time as clock
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np

from .build import make_scene_solver
from .load import SceneFile
from .script import make_tools

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh


@dataclass
class RunSummary:
    """What a run did.

    Attributes:
        steps: steps taken. simulated: simulated time [s]. seconds: wall-clock time of the steps [s].
        largest_displacement: the largest displacement of any M_S node from rest over the run [m], reached by
            ``largest_node`` at ``largest_time`` [s]; final_displacement: the largest at the end [m].
        forces: each tool's force on the tissue at the end, ``(3,) float64`` [N] (pressed pin-heads, probes and
            holding graspers).
        vertices_added: M_S vertices the cuts added.
        warning: the solver's sentence when the end state lies beyond linear elasticity, else None.
    """

    steps: int = 0
    simulated: float = 0.0
    seconds: float = 0.0
    largest_displacement: float = 0.0
    largest_node: int = -1
    largest_time: float = 0.0
    final_displacement: float = 0.0
    forces: dict[str, np.ndarray] = field(default_factory=dict)
    vertices_added: int = 0
    warning: str | None = None

    def lines(self) -> list[str]:
        """The summary as lines for a terminal."""
        lines = [f"{self.steps} steps, {self.simulated:.4g} s simulated in {self.seconds:.3g} s",
                 f"largest displacement {1e3 * self.largest_displacement:.4g} mm (node {self.largest_node} at "
                 f"t = {self.largest_time:.4g} s); at the end {1e3 * self.final_displacement:.4g} mm"]
        for name, force in self.forces.items():
            lines.append(f"{name}: force {np.linalg.norm(force):.4g} N, {np.round(force, 4).tolist()} N at the end")
        if self.vertices_added:
            lines.append(f"cuts added {self.vertices_added} surface vertices")
        if self.warning:
            lines.append(f"warning: {self.warning}")
        return lines


class Simulation:
    """The scene's solver over ``hybrid`` with its tools, ready to step.

    Attributes:
        solver: the method's :class:`~tissuesim.solvers.base.Solver`. tools: the :class:`~.script.ScriptedTool`
            list. steps: the run's step count. dt: its time step [s].
    """

    def __init__(self, loaded: SceneFile, hybrid: HybridMesh):
        self.scene_file = loaded
        self.solver = make_scene_solver(loaded, hybrid)
        self.tools = make_tools(loaded, self.solver)
        self.steps, self.dt = loaded.scene.run.steps, loaded.scene.run.dt
        self._start_vertices = self.solver.node_count

    def run(self, *, on_step: Callable[[float], object] | None = None, progress: bool = False) -> RunSummary:
        """Take every step; ``on_step(time)`` is called after each with the simulated time [s]; ``progress`` shows
        a tqdm bar on stderr."""
        from tqdm import tqdm

        summary = RunSummary()
        start = clock.perf_counter()
        for i in tqdm(range(self.steps), disable=not progress, unit="step", leave=False, desc="simulating"):
            for tool in self.tools:
                tool.update(i * self.dt)
            self.solver.step(self.dt)
            now = (i + 1) * self.dt
            self._track(summary, now)
            if on_step is not None:
                on_step(now)
        summary.seconds = clock.perf_counter() - start
        summary.steps, summary.simulated = self.steps, self.steps * self.dt
        summary.forces = {tool.name: tool.force for tool in self.tools if tool.force is not None}
        summary.vertices_added = self.solver.node_count - self._start_vertices
        summary.warning = self.solver.warning
        return summary

    def _track(self, summary: RunSummary, now: float) -> None:
        lengths = np.linalg.norm(self.solver.displacements, axis=1)
        node = int(np.argmax(lengths))
        summary.final_displacement = float(lengths[node])
        if lengths[node] > summary.largest_displacement:
            summary.largest_displacement, summary.largest_node, summary.largest_time = float(lengths[node]), node, now
