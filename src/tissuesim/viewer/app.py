"""The simulator's window: a thin polyscope layer over :class:`~tissuesim.viewer.controller.Controller`.

Each frame polyscope calls :meth:`ViewerApp.frame`, which (1) turns the mouse into pointer events — a left click
on the surface grasps (grasper), grabs (the paper's pin-head) or starts a cut (scalpel) and turns the camera's mouse
handling off until the button is released; a click beside the surface turns the camera as usual — (2) lets the
controller run the steps the elapsed wall time asks for, (3) pushes the new positions to the GPU, (4) writes a
recording frame, (5) draws the panel (:mod:`.panel`). Keys: S switches the hand tool (grasper or pin-head) / scalpel,
X lets go of everything held, R resets, space pauses, Q or Esc closes the window; releasing the button with Shift
held leaves the grasper or pin-head holding (a second hand).

The window is the model's view plus the panel beside it (:data:`VIEW_SIZE` + :data:`PANEL_WIDTH`), and the camera
centres the model in the free part (:func:`~tissuesim.viewer.gl.look_at_oblique`'s ``pane``), so the panel never
covers it. M_S is drawn as tissue (:mod:`.look`); the displacement colours are a switch of the panel.

:class:`~tissuesim.viewer.replay.ReplayApp` plays a recording (``tissuesim view --replay FILE.pvd``).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..cutting.walls import wound_walls
from ..errors import TissuesimError
from ..mesh.coincident import coincident_pairs
from ..recording import Recorder, Tools, border_edges, solver_frame, tools_of
from ..recording_place import session_path
from .controller import HANDS, Controller
from .figures import WALL_COLOR
from .gl import look_at_oblique, polyscope
from .look import SURFACE, TissueSurface  # noqa: F401  (SURFACE: the name scripts look the model up by)
from .panel import PanelWidgets
from .tool_layers import ToolLayers

if TYPE_CHECKING:
    from types import ModuleType

VIEW_SIZE = (940, 780)  # pixels: the model's part of the window
PANEL_WIDTH = 340  # pixels: the panel, beside the view
WINDOW_SIZE = (VIEW_SIZE[0] + PANEL_WIDTH, VIEW_SIZE[1])  # pixels
CUT_COLOR = (0.95, 0.85, 0.1)  # the cut's edges: yellow, apart from tissue, wound walls and the colour map
HOME_DISTANCE = 2.8  # camera distance at start, in half-diagonals of the model's box
FRAME_SMOOTHING = 0.05  # weight of the newest frame in the frame-rate running mean


class ViewerApp(PanelWidgets):
    """The window over ``controller``; ``record`` (a .pvd path) starts recording at once.

    The panel's record button names each recording after the time it starts (:func:`session_path`), in the folder
    of ``record`` or else the working folder, so no recording of the session replaces another.

    ``headless=True`` draws into polyscope's offscreen EGL context instead of a window (for scripts, tests and
    the benchmark, which call :meth:`tick`).
    """

    def __init__(self, controller: Controller, *, title: str = "", record: Path | str | None = None,
                 headless: bool = False):
        self.controller = controller
        self.title = title
        self.recorder = None if record is None else Recorder(record)
        self.record_path = None if record is None else self.recorder.path
        self.recorded: Path | None = None  # the last recording finished and in place
        self.record_folder = Path(".") if record is None else self.record_path.parent
        self.show_wireframe, self.show_control, self.show_colours = False, False, False
        self.colour_top = 1.0  # mm at the top of the colour map
        self.frame_seconds = 0.0  # running mean of the wall time between frames [s]
        self.render_seconds = 0.0  # last frame's time outside the callback: polyscope's drawing [s]
        self.callback_seconds = 0.0  # last frame's time inside the callback: events, steps, uploads, panel [s]
        self.stats = None
        self.sim_time = 0.0  # simulated seconds since the start [s]
        self._pending = {}  # slider values not yet applied (see PanelWidgets._apply_on_release)
        self._topology = None
        self._home_view = True
        self._coarse_for, self._coarse = None, None  # cache of _coarse_nodes
        self._shown = {}  # optional layer name -> its polyscope structure
        self._dragging = False
        self._held_count = 0
        self._scene_tools = None      # a scene's scripted tools, drawn (ToolLayers)
        self._own_tools = None        # the user's graspers, drawn (ToolLayers)
        self._mouse = None
        self._last = None
        self.headless = headless
        self.ps = polyscope(headless=headless)
        style_window(self.ps)

    # ------------------------------------------------------------------------------------------------ running
    def run(self) -> None:
        """Open the window and run until it is closed; then finish the recording and let go of the window. Also on
        Ctrl-C or SIGTERM (:func:`show_window`): the session is the user's, so what was recorded is kept, unlike a
        ``with Recorder(...)`` block, which an exception discards."""
        show_window(self.ps, self.frame, self.close)

    def tick(self) -> None:
        """One frame without a window: the callback, then polyscope's render (headless scripts)."""
        self.ps.set_user_callback(self.frame)
        self.ps.frame_tick()

    def stop_recording(self) -> Path | None:
        """Finish the recording, if one runs (the window goes on); returns its path, or None."""
        recorder, self.recorder = self.recorder, None
        if recorder is None:
            return None
        self.recorded = recorder.close()
        return self.recorded

    def close(self) -> None:
        """End the session: :meth:`stop_recording`, then let go of polyscope's callback and of every structure of
        this window (:func:`let_go`)."""
        self.stop_recording()
        self.mesh = self.surface = self.cut = self.walls = None
        self._shown, self._topology, self._home_view = {}, None, True
        let_go(self.ps)

    def frame(self) -> None:
        """Polyscope's per-frame callback."""
        import polyscope.imgui as psim

        now = time.perf_counter()
        elapsed = 0.0 if self._last is None else now - self._last
        self._last = now
        if elapsed > 0.0:  # the time outside this callback is polyscope's rendering and the window's event loop
            self.render_seconds = max(elapsed - self.callback_seconds, 0.0)
            self.frame_seconds = elapsed if self.frame_seconds == 0.0 else (
                (1.0 - FRAME_SMOOTHING) * self.frame_seconds + FRAME_SMOOTHING * elapsed)
        if not self.headless:  # headless, a script drives the controller: there is no mouse to read
            self._keys(psim)
            self._pointer(psim)
        self.stats = self.controller.advance(elapsed)
        self.sim_time += self.stats.steps * self.controller.settings.dt
        self.draw()
        if self.recorder is not None and self.stats.steps:
            self._record_frame()
        self._panel(psim)
        self.callback_seconds = time.perf_counter() - now

    # ---------------------------------------------------------------------------------------------- drawing
    def draw(self) -> None:
        """Send the controller's current surface (and the optional layers) to polyscope."""
        ps, solver = self.ps, self.controller.solver
        triangles = solver.hybrid.surface.triangles
        x = solver.positions
        if self._topology is not triangles:  # first frame, or a cut changed the surface: register anew
            self._topology = triangles
            self.mesh, self.surface, self.cut, self.walls, self._shown = None, None, None, None, {}  # wrappers first
            self._scene_tools = self._own_tools = None
            ps.remove_all_structures()
            self.surface = TissueSurface(ps, x, triangles, solver.rest_positions)
            self.mesh = self.surface.mesh
            cut = border_edges(triangles)
            self.cut = self.walls = None
            if len(cut):  # only the cut's own nodes: a network over every vertex would dot the whole surface
                self._cut_nodes, local = np.unique(cut, return_inverse=True)
                self.cut = ps.register_curve_network("cut edges", x[self._cut_nodes], local.reshape(-1, 2),
                                                     color=CUT_COLOR)
                self._lips = coincident_pairs(solver.rest_positions)      # the two sides of each cut vertex
                points, faces = self._wound_walls(x)
                if len(faces):
                    self.walls = ps.register_surface_mesh("wound walls", points, faces, color=WALL_COLOR,
                                                          material="flat", back_face_policy="identical")
            if self._home_view:  # first frame and reset only: a cut or a method change keeps the user's camera
                look_at_oblique(ps, x, distance=HOME_DISTANCE, pane=PANEL_WIDTH)
                self._home_view = False
        else:
            self.surface.update(x)
            if self.cut is not None:
                self.cut.update_node_positions(x[self._cut_nodes])
            if self.walls is not None:
                self.walls.update_vertex_positions(self._wound_walls(x)[0])
        mm = None
        if self.show_colours:
            mm = 1e3 * np.linalg.norm(solver.displacements, axis=1)
            self.colour_top = max(float(mm.max()), 1.0)
        self.surface.colour(mm, self.colour_top)
        self._layers(x)

    def _wound_walls(self, x):
        """The wound's walls at positions ``x``, down to the scalpel's depth (:func:`wound_walls`)."""
        scalpel = self.controller.scalpel
        depth = scalpel.depth if scalpel is not None else 0.0
        return wound_walls(x, self.controller.solver.hybrid.surface.triangles, self._lips, depth)

    def _layers(self, x) -> None:
        """The optional layers: registered when switched on (or after a re-registration), then only moved."""
        ps, hybrid, c = self.ps, self.controller.solver.hybrid, self.controller
        held = c.cursor is not None and c.pin.grabbed      # the pin-head is drawn while it holds, not after
        self._layer("M_V wireframe", self.show_wireframe, x[self._coarse_nodes()],  # M'_S: M_V's boundary
                    lambda p: ps.register_curve_network("M_V wireframe", p, hybrid.coarse_surface.edges,
                                                        color=(0.1, 0.2, 0.6), radius=0.0015))
        self._layer("control nodes", self.show_control, x[hybrid.control],
                    lambda p: ps.register_point_cloud("control nodes", p, color=(0.95, 0.6, 0.1), radius=0.004))
        self._layer("pin-head", held, c.cursor[None] if held else None,
                    lambda p: ps.register_point_cloud("pin-head", p, color=(0.85, 0.1, 0.1), radius=0.01))
        self._layer("spring", held, np.array([x[c.pin.node], c.cursor]) if held else None,  # eq 24's spring
                    lambda p: ps.register_curve_network("spring", p, np.array([[0, 1]]), color=(0.85, 0.1, 0.1),
                                                        radius=0.002))
        self._held_layers(x)
        if self._own_tools is None:         # first frame, or a cut registered the surface anew
            self._own_tools = ToolLayers(self.ps, "your")
        jaws = tools_of(graspers=c.grasper.jaws()).graspers
        self._own_tools.update(np.zeros((0, 2, 3)), np.zeros((0, 4)), graspers=jaws)
        self._scripted_layers(x)
        probe = c.probe.probe
        self._layer("probe", probe is not None, None if probe is None else probe.center[None],
                    lambda p: ps.register_point_cloud("probe", p, color=(0.7, 0.72, 0.78), material="wax"))
        if probe is not None:
            self._shown["probe"].set_radius(c.probe.radius, relative=False)
        fixed = c.brush.painted if c.brush.painting else c.solver.fixed
        self._layer("support", c.mode == "support" or c.support is not None, x[fixed],
                    lambda p: ps.register_point_cloud("support", p, color=(0.1, 0.3, 0.95), radius=0.006))
        ligaments = c.solver.attached_nodes
        if self._shown.get("ligaments") is not None and self._shown["ligaments"].n_points() != ligaments.size:
            self._shown.pop("ligaments").remove()      # a stroke added some: register anew
        self._layer("ligaments", ligaments.size > 0, x[ligaments],
                    lambda p: ps.register_point_cloud("ligaments", p, color=(0.1, 0.7, 0.25), radius=0.006))

    def _held_layers(self, x) -> None:
        """The pin-heads left holding: each cursor and its spring, re-registered when their number changes."""
        ps, held = self.ps, self.controller.held
        count = len(held)
        if count != self._held_count:
            for name in ("held pin-heads", "held springs"):
                if name in self._shown:
                    self._shown.pop(name).remove()
            self._held_count = count
        if not count:
            return
        cursors, nodes = held.cursors, held.nodes
        self._layer("held pin-heads", True, cursors,
                    lambda p: ps.register_point_cloud("held pin-heads", p, color=(0.95, 0.55, 0.1), radius=0.01))
        ends = np.concatenate([x[nodes], cursors])
        pairs = np.stack([np.arange(count), count + np.arange(count)], axis=1)
        self._layer("held springs", True, ends,
                    lambda p: ps.register_curve_network("held springs", p, pairs, color=(0.95, 0.55, 0.1),
                                                        radius=0.002))

    def _scripted_layers(self, x) -> None:
        """A scene's scripted pin-heads, probes and graspers, where they are now (:class:`~.tool_layers.ToolLayers`)."""
        playback = self.controller.playback
        if playback is None:
            return
        if self._scene_tools is None:       # first frame, or a cut registered the surface anew
            self._scene_tools = ToolLayers(self.ps, "scene")
        tools = tools_of(*playback.acting(x)[:2], graspers=playback.graspers())
        self._scene_tools.update(tools.pin_heads, tools.probes, graspers=tools.graspers)

    def recorded_tools(self) -> Tools:
        """Every tool acting now, for a recording: the graspers, the pin-head held, those left holding, the scene's
        scripted ones, the probes, and the scalpel's depth."""
        c = self.controller
        x = c.solver.positions
        pins = [(x[c.pin.node], c.cursor)] if c.pin.grabbed and c.cursor is not None else []
        pins += [(x[node], cursor) for node, cursor in zip(c.held.nodes, c.held.cursors)]
        probes = [] if c.probe.probe is None else [(c.probe.probe.center, c.probe.radius)]
        depth = 0.0 if c.scalpel is None else float(c.scalpel.depth)
        graspers = c.grasper.jaws()
        if c.playback is not None:
            scene_pins, scene_probes, scene_depth = c.playback.acting(x)
            pins, probes, depth = pins + scene_pins, probes + scene_probes, max(depth, scene_depth)
            graspers += c.playback.graspers()
        return tools_of(pins, probes, depth, graspers)

    def _layer(self, name: str, shown: bool, points, register) -> None:
        layer = self._shown.get(name)
        if not shown:
            if layer is not None:
                layer.remove()
                del self._shown[name]
        elif layer is None:
            self._shown[name] = register(points)  # radii relative to the scene's length scale
        elif hasattr(layer, "update_node_positions"):
            layer.update_node_positions(points)
        else:
            layer.update_point_positions(points)

    def _coarse_nodes(self) -> np.ndarray:
        """``(c0,)`` an M_S vertex at the rest position of each M'_S vertex: the control nodes before any cut; after
        one, a node released by it still marks its M'_S vertex (M_V and M'_S are never cut)."""
        hybrid = self.controller.solver.hybrid
        if self._coarse_for is not hybrid:
            from scipy.spatial import cKDTree

            _, nodes = cKDTree(self.controller.solver.rest_positions).query(hybrid.coarse_surface.vertices)
            self._coarse_for, self._coarse = hybrid, nodes
        return self._coarse

    # ---------------------------------------------------------------------------------------------- input
    def _pointer(self, psim) -> None:
        io = psim.GetIO()
        if not psim.IsMousePosValid() or (io.WantCaptureMouse and not self._dragging):
            return
        mouse = tuple(io.MousePos)
        moved, self._mouse = mouse != self._mouse, mouse
        c = self.controller
        if psim.IsMouseClicked(0):
            hit, ray = self._pick(mouse)
            c.pointer_down(hit, *ray)
            self._dragging = hit is not None and (c.holding or c.mode not in HANDS)
            self.ps.set_do_default_mouse_interaction(not self._dragging)
        elif psim.IsMouseReleased(0) and self._dragging:
            c.pointer_up(hold=io.KeyShift)
            self._dragging = False
            self.ps.set_do_default_mouse_interaction(True)
        elif moved and (self._dragging or c.mode == "pin"):
            # a hand tool drags along the camera ray alone: no pick (a render pass) while it holds
            hit, ray = (None, self._ray(mouse)) if self._dragging and c.mode in HANDS else self._pick(mouse)
            c.pointer_move(hit, *ray)

    def _pick(self, mouse):
        result = self.ps.pick(screen_coords=mouse)
        # every drawn structure lies on the surface (the pin-head under the cursor is hit first when hovering)
        hit = result.position if result.is_hit else None
        return hit, self._ray(mouse)

    def _ray(self, mouse):
        origin = np.asarray(self.ps.get_view_camera_parameters().get_position())
        return origin, self.ps.screen_coords_to_world_ray(mouse)

    def _keys(self, psim) -> None:
        if psim.GetIO().WantCaptureKeyboard:
            return
        if quit_pressed(psim):
            self.ps.unshow()  # the window closes after this frame; run() then ends the session
            return
        for key, name in ((psim.ImGuiKey_S, "s"), (psim.ImGuiKey_X, "x"), (psim.ImGuiKey_R, "r"),
                          (psim.ImGuiKey_Space, "space")):
            if psim.IsKeyPressed(key, False):
                self.controller.key(name)
                if name == "r":
                    self._topology, self._home_view = None, True

    # ---------------------------------------------------------------------------------------------- recording
    def _record_frame(self) -> None:
        """Add the current frame; a frame that cannot be written (a full disk) ends the recording, discarded, and
        the session goes on."""
        try:
            self.recorder.add(solver_frame(self.controller.solver, self.sim_time, tools=self.recorded_tools()))
        except TissuesimError as error:
            self.recorder.abort()
            self.recorder = None
            self.controller.notice = f"recording stopped and discarded: {error}"

    def _toggle_recording(self) -> None:
        """The panel's record / stop recording: a new recording under a fresh name, starting with the current
        frame; or the running one finished, while the window goes on."""
        try:
            if self.recorder is None:
                self.record_path = session_path(self.record_folder)
                self.recorder = Recorder(self.record_path)
                self.recorder.add(solver_frame(self.controller.solver, self.sim_time, tools=self.recorded_tools()))
                self.controller.notice = f"recording to {self.record_path}"
            else:
                self.controller.notice = f"recorded to {self.stop_recording()}"
        except TissuesimError as error:
            self.controller.notice = str(error)


def style_window(ps: ModuleType) -> None:
    """z up, no ground shadow (its pass costs more than the rest of a software-rendered frame), our panel only, beside
    the view."""
    ps.set_up_dir("z_up")
    ps.set_front_dir("neg_y_front")
    ps.set_ground_plane_mode("none")
    ps.set_window_size(*WINDOW_SIZE)
    ps.set_build_default_gui_panels(False)
    ps.set_user_gui_is_on_right_side(True)
    ps.set_right_gui_pane_width(PANEL_WIDTH)


def quit_pressed(psim: ModuleType) -> bool:
    """Whether Q or Esc went down this frame (the window's quit keys)."""
    return psim.IsKeyPressed(psim.ImGuiKey_Q, False) or psim.IsKeyPressed(psim.ImGuiKey_Escape, False)


def show_window(ps: ModuleType, frame: Callable[[], None], end: Callable[[], object]) -> None:
    """Run polyscope's window with ``frame`` as its per-frame callback until it is closed; then ``end()``."""
    ps.set_user_callback(frame)
    try:
        ps.show()
    finally:
        end()


def let_go(ps: ModuleType) -> None:
    """Drop polyscope's callback and every structure. The Python wrappers of removed structures must not outlive
    them (the callers drop theirs first): a new structure allocated at the same address would then come back as the
    stale wrapper's type."""
    ps.clear_user_callback()
    ps.remove_all_structures()
