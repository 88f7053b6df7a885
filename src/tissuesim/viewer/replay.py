"""``tissuesim view --replay FILE.pvd``: a recording (:func:`tissuesim.recording.read_recording`) played back in the
simulator's window, drawn as the simulator draws it (:mod:`.look`), with the cut's edges, the wound's walls down to
the recorded blade's depth, the recorded pin-heads (ball and spring) and probes where they were, and the |u| colour
map."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..cutting.walls import wound_walls
from ..errors import TissuesimError
from ..mesh.coincident import coincident_pairs
from .app import CUT_COLOR, HOME_DISTANCE, PANEL_WIDTH, let_go, quit_pressed, show_window, style_window
from .figures import WALL_COLOR
from .gl import look_at_oblique, polyscope
from .look import TissueSurface
from .tool_layers import ToolLayers

if TYPE_CHECKING:
    from ..recording import Frame


class ReplayApp:
    """Plays the frames of a recording (:func:`tissuesim.recording.read_recording`) with a slider and play button:
    the tissue as the simulator draws it, the cut's edges in :data:`CUT_COLOR`, and the |u| colour map (with its
    legend) as a switch."""

    def __init__(self, frames: Sequence[Frame], *, title: str = "", headless: bool = False):
        if not frames:
            raise TissuesimError("the recording holds no frame")
        self.frames, self.title = frames, title
        self.index, self.playing, self._topology = 0, True, None
        self.show_colours, self.headless = False, headless
        self.surface = self.cut = self.walls = self.tools = None
        self.ps = polyscope(headless=headless)
        style_window(self.ps)

    def run(self) -> None:
        """Open the window and play until it is closed."""
        show_window(self.ps, self.frame, self.close)

    def close(self) -> None:
        """Let go of polyscope (:func:`let_go`)."""
        self.mesh = self.surface = self.cut = self.walls = self.tools = None
        self._topology = None
        let_go(self.ps)

    def frame(self) -> None:
        import polyscope.imgui as psim

        frame = self.frames[self.index]
        if self._topology is not frame.triangles:
            self._topology, self.mesh, self.surface, self.cut, self.walls = frame.triangles, None, None, None, None
            self.ps.remove_all_structures()
            self.tools = ToolLayers(self.ps, "recorded")
            rest = frame.positions - frame.displacement
            self.surface = TissueSurface(self.ps, frame.positions, frame.triangles, rest)
            self.mesh = self.surface.mesh
            cut = frame.cut_edges
            if len(cut):
                self._cut_nodes, local = np.unique(cut, return_inverse=True)
                self.cut = self.ps.register_curve_network("cut edges", frame.positions[self._cut_nodes],
                                                          local.reshape(-1, 2), color=CUT_COLOR)
                self._lips = coincident_pairs(rest)
            if self.index == 0:
                look_at_oblique(self.ps, frame.positions, distance=HOME_DISTANCE, pane=PANEL_WIDTH)
        self.surface.update(frame.positions)
        if self.cut is not None:
            self.cut.update_node_positions(frame.positions[self._cut_nodes])
            self._walls(frame)
        self.tools.update(frame.tools.pin_heads, frame.tools.probes, graspers=frame.tools.graspers)
        mm = 1e3 * np.linalg.norm(frame.displacement, axis=1)
        top = max(float(mm.max()), 1.0)
        self.surface.colour(mm if self.show_colours else None, top)
        force = np.linalg.norm(frame.force, axis=1).max()
        psim.TextUnformatted(self.title or " ")
        psim.TextUnformatted(f"t = {frame.time:.3f} s   force {force:.3f} N")
        psim.TextUnformatted(f"{len(self._cut_nodes) if self.cut is not None else 0} vertices on cut edges (yellow)")
        pins, probes = len(frame.tools.pin_heads), len(frame.tools.probes)
        psim.TextUnformatted(f"tools: {pins} pin-head{'s' * (pins != 1)} (red), {probes} probe{'s' * (probes != 1)}")
        _, self.show_colours = psim.Checkbox("|u| colours", self.show_colours)
        psim.SameLine()
        psim.TextDisabled(f"0 to {top:.1f} mm, viridis" if self.show_colours else "off: tissue shading")
        _, self.playing = psim.Checkbox("play", self.playing)
        psim.SameLine()
        psim.TextDisabled("Q or Esc quits")
        if not self.headless and quit_pressed(psim):
            self.ps.unshow()
        changed, index = psim.SliderInt("frame", self.index, 0, len(self.frames) - 1)
        if changed:
            self.index, self.playing = index, False
        elif self.playing:
            self.index = (self.index + 1) % len(self.frames)

    def _walls(self, frame) -> None:
        """The wound's walls down to the recorded blade's depth (none where the recording has no depth)."""
        points, faces = wound_walls(frame.positions, frame.triangles, self._lips, frame.tools.blade_depth)
        if self.walls is not None and len(faces) != self.walls.n_faces():
            self.walls.remove()
            self.walls = None
        if not len(faces):
            return
        if self.walls is None:
            self.walls = self.ps.register_surface_mesh("wound walls", points, faces, color=WALL_COLOR,
                                                       material="flat", back_face_policy="identical")
        else:
            self.walls.update_vertex_positions(points)
