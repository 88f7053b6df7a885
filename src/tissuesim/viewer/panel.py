"""The simulator window's panel (:class:`~tissuesim.viewer.app.ViewerApp`'s ImGui widgets): tool, hints, method,
material and time settings, timings, record and reset buttons, the layers to show and the controller's notice.

Its rows keep their places: a row that says something only at times (what is left holding, the slower-than-real-time
and beyond-small-strain status, the colour legend, the near field after a cut) is always drawn, blank or greyed out
when it has nothing to say, so the next click lands on the widget it was aimed at. What changes with the user's own
choice (the method's options, the tool's settings) sits below the fixed rows, and the notice comes last.
A control shows where it acts: the iterations only for a step that iterates (:func:`iterations_act`).

A setting that rebuilds the solver goes to the controller through :meth:`PanelWidgets._configure`; one whose slider
would rebuild it on every pixel of a drag waits until the slider is let go.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import TissuesimError
from ..fem.hyperelastic import MATERIALS
from ..solvers.near_field import NEAR_FIELD_WINDOW
from ..solvers.registry import available_solvers, solver_class, solver_options
from .controller import MODES

if TYPE_CHECKING:
    from ..solvers.base import Solver
    from .controller import Controller

MODE_LABELS = {"grasper": "grasper", "pin": "pin-head (paper)", "probe": "probe", "scalpel": "scalpel",
               "support": "support"}
STANDARD_GRAVITY = 9.81  # m/s²: the panel's gravity, straight down the model's z
PANEL_ITEM_WIDTH = 150  # pixels of one widget: with the panel's width, it leaves the model in view
PAIR_ITEM_WIDTH = 85  # pixels of a widget two to a row (E and nu; dt and prestrain), so the panel fits the window
BEHIND = (1.0, 0.35, 0.2, 1.0)  # colour of the slower-than-real-time notice
#: The keys, two lines that fit the panel.
KEY_HINTS = ("keys: S hand tool / scalpel   X let go   R reset", "      space pause   Q or Esc quit")
#: What the mouse does on the model in each mode (beside it, as in every polyscope window, a drag turns the view).
MOUSE_HINTS = {"grasper": "drag on the tissue: carry it; Shift + release: hold",
               "pin": "drag on the tissue: pull; Shift + release: hold",
               "probe": "press on the tissue; Shift + release: hold",
               "scalpel": "drag across the tissue: cut",
               "support": "drag on the tissue: paint (fixed blue, ligament green)"}


def held_line(c: Controller) -> str:
    """What the controller ``c`` has left holding, with the pull of each kind [N], or "" for nothing."""
    graspers = len(c.grasper.held)
    pins = len(c.held)
    parts = []
    if graspers:
        pulling = sum(float(np.linalg.norm(grasper.force)) for grasper in c.grasper.held)
        parts.append(f"{graspers} grasper{'s' * (graspers != 1)} {pulling:.2f} N")
    if pins:
        pulling = sum(float(np.linalg.norm(pin.force(cursor))) for pin, cursor in zip(c.held.pins, c.held.cursors))
        parts.append(f"{pins} pin-head{'s' * (pins != 1)} {pulling:.2f} N")
    if c.probe.held and c.probe.pressing:
        parts.append("probe")
    return "holding " + " + ".join(parts) if parts else ""


def iterations_act(solver: Solver) -> bool:
    """Whether ``solver``'s step depends on its PBD iterations: the paper's pbd form, or the layer's xpbd
    integrator. The default step of the hybrid and pbd methods (xpbd form, implicit integrator) solves the layer's
    linear system, and the other methods have no iterations."""
    return getattr(solver, "form", None) == "pbd" or getattr(solver, "integrator", None) == "xpbd"


class PanelWidgets:
    """The panel half of :class:`~tissuesim.viewer.app.ViewerApp`, which draws it each frame (:meth:`_panel`).

    It reads the app's ``controller``, ``title``, ``recorder``, ``stats`` and frame timings, sets its layer switches
    (``show_*``), calls its ``_toggle_recording``, and after a reset or a rebuild drops its registered surface
    (``_topology``) so that the next frame registers it anew; its slider values not yet applied are ``_pending``.
    """

    def _panel(self, psim) -> None:
        """The panel, drawn each frame after the surface."""
        c, s = self.controller, self.controller.settings
        psim.PushItemWidth(PANEL_ITEM_WIDTH)
        psim.TextUnformatted(self.title or " ")
        for number, mode in enumerate(MODES):      # two to a row: more in one would run past the panel
            if psim.RadioButton(MODE_LABELS[mode], c.mode == mode):
                c.set_mode(mode)
            if number % 2 == 0 and number + 1 < len(MODES):
                psim.SameLine()
        for line in KEY_HINTS:
            psim.TextDisabled(line)
        psim.TextUnformatted(MOUSE_HINTS[c.mode])
        psim.Separator()
        self._held(psim, c)
        self._timing(psim)
        if psim.Button("reset (R)"):
            c.reset()
            self._topology, self._home_view = None, True
        psim.SameLine()
        if psim.Button("stop recording" if self.recorder else "record"):
            self._toggle_recording()
        psim.SameLine()
        self._gravity(psim, c)
        _, self.show_wireframe = psim.Checkbox("M_V wireframe", self.show_wireframe)
        psim.SameLine()
        _, self.show_control = psim.Checkbox("control nodes", self.show_control)
        _, self.show_colours = psim.Checkbox("|u| colours", self.show_colours)
        psim.SameLine()
        psim.TextDisabled(f"0 to {self.colour_top:.1f} mm, viridis" if self.show_colours else "off: tissue shading")
        psim.Separator()
        methods = list(available_solvers())
        changed, index = psim.Combo("method", methods.index(s.method), methods)
        if changed:
            self._configure(method=methods[index])
        self._material(psim, s)
        if c.mode in ("grasper", "probe", "support"):
            psim.Separator()
            if c.mode == "grasper":
                self._grasper(psim, c.grasper)
            elif c.mode == "probe":
                self._probe(psim, c.probe)
            else:
                self._support(psim, c)
        if c.notice:
            psim.Separator()
            psim.TextWrapped(c.notice)
        psim.PopItemWidth()

    @staticmethod
    def _held(psim, c) -> None:
        """One row: the graspers and pin-heads left holding and their pull, and the probe left pressing, and the
        button that lets them go (greyed when nothing holds)."""
        line = held_line(c)
        psim.BeginDisabled(not line)
        if psim.Button("let go (X)"):
            c.release_held()
        psim.EndDisabled()
        psim.SameLine()
        psim.TextUnformatted(line or "nothing holding")

    def _gravity(self, psim, c) -> None:
        gravity = c.solver_options.get("gravity") is not None
        changed, gravity = psim.Checkbox("gravity (-z)", gravity)
        if changed:
            c.set_solver_option("gravity", (0.0, 0.0, -STANDARD_GRAVITY) if gravity else None)
            self._topology = None

    def _support(self, psim, c) -> None:
        """The brush: what it paints (the fixed region or a ligament), its size, and the ways back."""
        for paints in ("fixed", "ligament"):
            if psim.RadioButton(f"paint {paints}", c.brush.paints == paints):
                c.brush.paints = paints
            psim.SameLine()
        psim.NewLine()
        changed, brush_mm = psim.SliderFloat("brush [mm]", 1e3 * c.brush.radius, 1.0, 50.0, "%.1f")
        if changed:
            c.brush.radius = 1e-3 * brush_mm
        if c.brush.paints == "ligament":
            changed, k = psim.SliderFloat("ligament k [N/m]", c.brush.ligament_stiffness, 1.0, 5000.0, "%.0f",
                                          psim.ImGuiSliderFlags_Logarithmic)
            if changed:
                c.brush.ligament_stiffness = k
        psim.BeginDisabled(not c.solver_options.get("attachments"))     # both always drawn: greyed when idle
        if psim.Button("drop ligaments"):
            c.set_solver_option("attachments", None)
            self._topology = None
        psim.EndDisabled()
        psim.SameLine()
        psim.BeginDisabled(c.support is None)
        if psim.Button("default support"):
            c.set_support(None)
            self._topology = None
        psim.EndDisabled()

    @staticmethod
    def _grasper(psim, tool) -> None:
        """The jaws' reach, and what they hold."""
        changed, reach_mm = psim.SliderFloat("jaws' reach [mm]", 1e3 * tool.radius, 1.0, 30.0, "%.1f")
        if changed:
            tool.radius = 1e-3 * reach_mm     # the next grab
        if tool.grasping:
            grasper = tool.grasper
            psim.TextUnformatted(f"holding {grasper.held.size} vertices, torque "
                                 f"{1e3 * np.linalg.norm(grasper.torque):.2f} mN m")
        else:
            psim.TextWrapped("press on the tissue and drag: it goes where the jaws go; Shift + release keeps it held")

    @staticmethod
    def _probe(psim, tool) -> None:
        """The probe's radius and press depth, and its contact force."""
        changed, radius_mm = psim.SliderFloat("probe radius [mm]", 1e3 * tool.radius, 1.0, 40.0, "%.1f")
        if changed and not tool.pressing:     # a pressing probe keeps its size: let go first
            tool.radius = 1e-3 * radius_mm
        changed, depth_mm = psim.SliderFloat("press depth [mm]", 1e3 * tool.depth, 0.0, 1e3 * tool.radius, "%.1f")
        if changed:
            tool.depth = 1e-3 * depth_mm      # the next press
        if tool.pressing:
            psim.TextUnformatted(f"probe force {np.linalg.norm(tool.force):.3f} N on {tool.probe.contacts.size} "
                                 "vertices")
        else:
            psim.TextWrapped("press on the surface; Shift + release keeps it pressing")

    def _finite_strain(self, psim, s) -> None:
        """The material selector where the method has finite strain; a line saying so where it has not."""
        if set(MATERIALS) <= set(solver_class(s.method).materials):
            changed, index = psim.Combo("strain", MATERIALS.index(s.material), list(MATERIALS))
            if changed:
                self._configure(material=MATERIALS[index])
        else:                         # one row either way: greyed, and saying why
            psim.BeginDisabled(True)
            psim.Combo(f"strain ({s.method}: its own model)", 0, ["linear"])
            psim.EndDisabled()

    def _material(self, psim, s) -> None:
        enter = psim.ImGuiInputTextFlags_EnterReturnsTrue
        psim.PushItemWidth(PAIR_ITEM_WIDTH)
        changed, e = psim.InputFloat("E [Pa]", s.youngs_modulus, 0.0, 0.0, "%.0f", enter)
        if changed:
            self._configure(youngs_modulus=e)
        psim.SameLine()
        _, self._pending["poisson_ratio"] = psim.SliderFloat("nu", self._pending.get("poisson_ratio",
                                                                                     s.poisson_ratio), 0.0, 0.49)
        self._apply_on_release(psim, "poisson_ratio")
        psim.PopItemWidth()
        changed, k = psim.SliderFloat("k [N/m]", s.stiffness, 1.0, 500.0, "%.1f", psim.ImGuiSliderFlags_Logarithmic)
        if changed:
            self._configure(stiffness=k)
        radius_mm = 1e3 * (s.radius or 0.0)  # 0: one node
        changed, radius_mm = psim.SliderFloat("contact radius [mm]", radius_mm, 0.0, 20.0, "%.1f")
        if changed:
            self._configure(radius=radius_mm * 1e-3 if radius_mm > 0 else None)
        # each row below is drawn for every method, greyed where it does not apply, so that switching the method
        # moves no row and a click lands on the widget it was aimed at
        iterating = "iterations" in solver_options(s.method) and iterations_act(self.controller.solver)
        current = s.iterations or solver_options(s.method).get("iterations") or 1
        psim.BeginDisabled(not iterating)
        _, pending = psim.SliderInt("iterations" if iterating else "iterations (unused)",
                                    self._pending.get("iterations", current), 1, 50)
        psim.EndDisabled()
        if iterating:
            self._pending["iterations"] = pending
            self._apply_on_release(psim, "iterations")
        self._finite_strain(psim, s)
        hybrid = self.controller.element_available()
        psim.BeginDisabled(not hybrid)
        changed, on = psim.Checkbox("quadratic M_V (as accurate as the fine FEM)" if hybrid else
                                    "quadratic M_V (the hybrid's)", hybrid and s.element == "quadratic")
        psim.EndDisabled()
        if changed and hybrid:
            self._configure(element="quadratic" if on else "linear", near_field=None)
        available = self.controller.near_field_available()
        psim.BeginDisabled(not available)
        if "near_field" not in solver_options(s.method):
            why = "the hybrid's"
        else:
            why = "the quadratic M_V replaces it" if s.element == "quadratic" else "cut, or no fine volume"
        label = (f"near field ({1e3 * NEAR_FIELD_WINDOW:g} mm, quadratic fine volume)" if available else
                 f"near field: off ({why})")
        changed, on = psim.Checkbox(label, available and s.near_field is not None)
        psim.EndDisabled()
        if changed and available:
            self._configure(near_field=NEAR_FIELD_WINDOW if on else None)
        psim.PushItemWidth(PAIR_ITEM_WIDTH)
        changed, dt_ms = psim.InputFloat("dt [ms]", 1e3 * s.dt, 0.0, 0.0, "%.2f", enter)
        if changed:
            self._configure(dt=dt_ms * 1e-3)
        psim.SameLine()
        prestressed = "prestrain" in solver_options(s.method)
        psim.BeginDisabled(not prestressed)
        _, pending = psim.SliderFloat("prestrain", self._pending.get("prestrain", s.prestrain), 0.0, 0.3, "%.3f")
        psim.EndDisabled()
        if prestressed:
            self._pending["prestrain"] = pending
            self._apply_on_release(psim, "prestrain")
        psim.PopItemWidth()

    def _timing(self, psim) -> None:
        st, c = self.stats, self.controller
        step_ms = 1e3 * st.step_seconds if st else 0.0
        fps = 1.0 / self.frame_seconds if self.frame_seconds else 0.0
        psim.TextUnformatted(f"step {step_ms:.2f} ms   draw {1e3 * self.render_seconds:.1f} ms   {fps:.0f} frames/s")
        if c.probe.pressing:          # the tool that acts: the probe's push, the jaws' pull, else the pin-head's
            acting = f"probe {np.linalg.norm(c.probe.force):.3f} N"
        elif c.mode == "grasper":
            acting = f"grasper {np.linalg.norm(c.grasper.force):.3f} N"
        else:
            acting = f"force {c.force_newtons:.3f} N" + (f" on node {c.pin.node}" if c.pin.grabbed else "")
        psim.TextUnformatted(f"t = {self.sim_time:.2f} s   {acting}")
        if c.playback is not None:             # a scene's script: one row for the whole session
            psim.TextWrapped(c.playback.status())
        pace = ""                                    # two status rows, blank when all is well
        if c.paused:
            pace = "paused (space)"
        elif st and (st.behind or st.dropped > 0.0):
            pace = "slower than real time (a step > dt)" if st.behind else "slower than real time (drawing)"
        psim.TextColored(BEHIND, pace or " ")
        strain = ""
        if c.solver.warning and c.settings.material == "linear":    # a model used beyond its validity says so
            strain = f"beyond small strain ({c.solver.largest_displacement / c.solver.size:.2f} of the size)"
        psim.TextColored(BEHIND, strain or " ")

    def _apply_on_release(self, psim, name: str) -> None:
        """Settings that rebuild the solver change when the slider is let go, not on every pixel of the drag."""
        if psim.IsItemDeactivatedAfterEdit():
            self._configure(**{name: self._pending.pop(name)})
        elif not psim.IsItemActive():
            self._pending.pop(name, None)

    def _configure(self, **changes) -> None:
        try:
            self.controller.configure(**changes)
            self._topology = None
        except TissuesimError as error:
            self.controller.notice = str(error)
