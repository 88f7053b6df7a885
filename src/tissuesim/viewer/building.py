"""How the simulator's :class:`~tissuesim.viewer.controller.Controller` builds its solver and tools from the
settings: a mixin, so that a change of method, material or support swaps in a new solver, pin-head, held pin-heads,
graspers, probe and scalpel all at once, or (refused) changes nothing."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields, replace
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SolverError, TissuesimError
from ..tools.pinhead import PinHead
from ..solvers.registry import make_solver, solver_class, solver_options
from .settings import Settings, checked_settings

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..mesh.hybrid import HybridMesh

# settings whose change needs a new solver (the others are set on the live objects)
_REBUILD = ("method", "youngs_modulus", "poisson_ratio", "iterations", "prestrain", "near_field", "material",
            "element")
# solver options the settings own: a scene or a script gives them through Settings, not solver_options
_SETTINGS_OPTIONS = ("youngs_modulus", "poisson_ratio", "dt", "iterations", "prestrain", "near_field", "material",
                     "element")


class SolverBuilding:
    """The building half of :class:`~tissuesim.viewer.controller.Controller` (see there for the attributes)."""

    def set_support(self, vertices: ArrayLike | None) -> None:
        """Fix ``vertices`` ``(k,)`` of the current mesh (None: back to the scene's or the model's bottom): a new
        solver over the same mesh, holding what was held. A region that cannot hold the body is refused, with
        nothing changed, and :attr:`notice` says why."""
        support = None if vertices is None else np.unique(np.asarray(vertices)).astype(np.int32)
        if self._rebuilt_with("support", support, refusal="that support was refused"):
            self.notice = ("support: the model's default" if vertices is None else
                           f"support: {self.support.size} painted vertices fixed")

    def set_solver_option(self, name: str, value: object) -> None:
        """Give every solver from now on the option ``name`` = ``value`` (None: drop it), e.g. ``gravity`` or
        ``attachments``: a new solver over the same mesh, holding what was held. A refused option (a bad value, or
        the method has none such) changes nothing, and :attr:`notice` says why."""
        options = extra_options({**self.solver_options, name: value})
        if value is None:
            options.pop(name)
        if self._rebuilt_with("solver_options", options, refusal=f"{name} was refused"):
            self.notice = ""

    def _rebuilt_with(self, attribute: str, value, *, refusal: str) -> bool:
        """``attribute`` set to ``value`` and a new solver over the same mesh, holding what was held; where the
        solver refuses, the attribute goes back, :attr:`notice` says why after ``refusal``, and False comes back."""
        old = getattr(self, attribute)
        setattr(self, attribute, value)
        try:
            self._build(self.solver.hybrid, carry=True)
        except TissuesimError as error:
            setattr(self, attribute, old)
            self.notice = f"{refusal}: {error}"
            return False
        return True

    def add_ligament(self, vertices: ArrayLike, *, stiffness: float) -> None:
        """Hold ``vertices`` ``(k,)`` of the current mesh by a ligament of total ``stiffness`` [N/m] to their rest
        positions (:class:`~tissuesim.solvers.attachments.Attachment`), beside the ligaments there are."""
        from ..solvers.attachments import Attachment

        try:
            ligament = Attachment(nodes=np.unique(np.asarray(vertices)), stiffness=stiffness)
        except TissuesimError as error:
            self.notice = f"that ligament was refused: {error}"
            return
        self.set_solver_option("attachments", (*self.solver_options.get("attachments", ()), ligament))

    def configure(self, **changes: object) -> None:
        """Change settings live (the :class:`Settings` fields); a bad value leaves everything as it was."""
        names = [field.name for field in fields(Settings)]
        unknown = [name for name in changes if name not in names]
        if unknown:
            raise SolverError(f"unknown setting {', '.join(map(repr, unknown))}; the settings are {', '.join(names)}")
        settings, old = checked_settings(replace(self.settings, **changes)), self.settings
        rebuild = any(getattr(settings, name) != getattr(old, name) for name in _REBUILD)
        self.settings = settings
        try:
            if rebuild:
                self._build(self.solver.hybrid, carry=True)
            else:
                self._apply_live()
        except TissuesimError:  # e.g. a contact radius reaching the fixed region
            self.settings = old
            if not rebuild:
                self._apply_live()
            raise

    def _apply_live(self) -> None:
        """The settings that need no new solver: dt, k, the contact radius (re-applied to a held pin-head)."""
        self.solver.dt = self.settings.dt
        self.pin.stiffness, self.pin.radius = self.settings.stiffness, self.settings.radius
        if self.pin.grabbed and self.cursor is not None:
            self.force = self.pin.drag(self.cursor)
        self.held.restiffen(stiffness=self.settings.stiffness, radius=self.settings.radius)

    # ---------------------------------------------------------------------------------------------- time
    def _solver_options(self, hybrid) -> dict:
        s = self.settings
        options = {"youngs_modulus": s.youngs_modulus, "poisson_ratio": s.poisson_ratio, "dt": s.dt}
        if s.iterations is not None and "iterations" in solver_options(s.method):
            options["iterations"] = int(s.iterations)
        if s.prestrain > 0.0 and "prestrain" in solver_options(s.method):
            options["prestrain"] = float(s.prestrain)
        if s.near_field is not None and self.near_field_available(hybrid):
            options["near_field"] = float(s.near_field)
        if s.element != "linear" and self.element_available():
            options["element"] = s.element
        if self.finite_strain_available():
            options["material"] = s.material
        options.update(self.solver_options)
        if self.support is not None:  # painted on this mesh or an earlier, uncut one: its vertices come first
            options["fixed"] = self.support[self.support < hybrid.surface.vertex_count]
        return options

    def finite_strain_available(self) -> bool:
        """Whether the current method takes the ``material`` setting."""
        return self.settings.material in solver_class(self.settings.method).materials

    def near_field_available(self, hybrid: HybridMesh | None = None) -> bool:
        """Whether the method takes a near field on ``hybrid`` (default: the current mesh): uncut, with its fine
        volume, and M_V's linear elements (the quadratic M_V replaces it)."""
        mesh = self.solver.hybrid if hybrid is None else hybrid
        return ("near_field" in solver_options(self.settings.method) and mesh.fine_volume is not None
                and not mesh.info.get("cuts") and self.settings.element == "linear")

    def element_available(self) -> bool:
        """Whether the current method takes the ``element`` setting (the hybrid's M_V)."""
        return "element" in solver_options(self.settings.method)

    def _build(self, hybrid, *, carry: bool = False) -> None:
        """A fresh solver, pin-head and scalpel over ``hybrid``; with ``carry``, re-grab a held node and the
        graspers' patches. Everything is built first and swapped in only then, so a refusal (a method that cannot
        run here, a contact radius or a support that reaches the fixed region from what is held) leaves the
        controller as it was."""
        held = (self.pin.node, self.pin.anchor) if carry and self.pin.grabbed else None
        solver = make_solver(self.settings.method, hybrid, **self._solver_options(hybrid))
        pin = PinHead(solver, stiffness=self.settings.stiffness, radius=self.settings.radius)
        holding = self.held.moved_to(solver, stiffness=self.settings.stiffness, radius=self.settings.radius) \
            if carry else []
        probe = self.probe.moved_to(solver) if carry else None
        graspers = self.grasper.moved_to(solver) if carry else ([], None)
        force = np.zeros(3)
        if held is not None:
            pin.node, pin.anchor = held
            if self.cursor is not None:
                force = pin.drag(self.cursor)  # on the new solver, not yet the live one
        else:
            solver.step(self.settings.dt)  # at rest: builds what the first step needs (a factorisation) while loading
        scalpel, no_scalpel = self._new_scalpel(solver)
        if self._cutting:  # the new solver's scalpel is not pressed: the cut so far stays, the blade is lifted
            self.pointer_up()
        self.solver, self.pin, self.force = solver, pin, force
        self.held.adopt(holding)
        self.probe.adopt(probe)
        self.grasper.adopt(graspers)
        self.scalpel, self._no_scalpel = scalpel, no_scalpel
        if self.scalpel is None and self.mode == "scalpel":
            self.mode = self._hand
        elif self.mode == "scalpel":
            self._prepare_scalpel()
        self._debt = 0.0
        self._step_seconds = 0.0
        if held is None and self.mode == "pin":
            self.cursor = None

    def _prepare_scalpel(self) -> None:
        """Let the scalpel get ready while the user aims (the first cut's factor); a scalpel without ``prepare``
        needs none."""
        prepare = getattr(self.scalpel, "prepare", None)
        if prepare is not None:
            prepare()

    def _new_scalpel(self, solver):
        """``(scalpel or None, why there is none)`` over ``solver``."""
        if self._scalpel_factory is None:
            return None, "scalpel mode needs tissuesim.Scalpel, which this installation lacks"
        try:
            return self._scalpel_factory(solver), ""
        except TissuesimError as error:  # e.g. a method that cannot be cut
            return None, f"no scalpel with the {solver.name} method: {error}"

def extra_options(options: Mapping[str, object] | None) -> dict:
    """``options`` for :class:`Controller`'s ``solver_options`` as a dict, or SolverError for one that the
    settings hold."""
    options = dict(options or {})
    owned = sorted(set(options) & set(_SETTINGS_OPTIONS))
    if owned:
        raise SolverError(f"solver_options {', '.join(owned)} belong to the viewer's Settings (the panel changes "
                          "them live); give them in settings=Settings(...) instead")
    return options
