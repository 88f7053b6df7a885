"""The surface layer as a solver: the part the ``pbd`` method (:mod:`.pbd`) and the hybrid (:mod:`.hybrid`) share.

The surface layer is M_S with a stretch constraint per edge (eq 8–9) and a bending constraint per interior edge
(eq 10–12); control nodes (hybrid) and fixed nodes are prescribed (eq 17's first case). Two forms (option ``form``):

* ``"xpbd"`` (default): a physical elastic layer. Compliance from the material (:mod:`tissuesim.layer.compliance`):
  a membrane + shell of Young's modulus E, Poisson ratio ν and a thickness that is ``thickness_ratio`` β times the
  constraint's own rest edge length, so the layer is as thick as the mesh is fine, and β is dimensionless.
  ``solve_static`` solves the layer's small-strain equilibrium exactly (:mod:`tissuesim.layer.static`): the same for
  every dt, node mass, density and sweep count, proportional to 1/E and responding to ν (through the plate rigidity
  E h³/(12(1 − ν²))). ``step`` is implicit Euler of that linear layer (``integrator="implicit"``, default: it rests
  at the same equilibrium) or the XPBD projection (``integrator="xpbd"``: one Numba call with eq 15, 16, 18; it
  rests off the static answer by an amount set by dt and the sweeps). β is the one free scalar, calibrated once.
* ``"pbd"``: the paper's stiffness coefficients ``stiffness`` k in (0, 1] for stretch and bending (Müller's
  per-iteration correction makes them independent of the iteration count). **Its equilibrium depends on dt and the
  node masses, and not on E**: a load's push per step is f dt²/m against a projection of strength k, so the
  effective stiffness is k m/dt² (measured on the cube, 1 N on the top node: 11.6 / 21.9 / 46.8 mm for
  dt = 5 / 10 / 20 ms). Kept to reproduce the paper; ``mass_scale`` (a factor on the masses) is its calibrated scalar
  for the ``pbd`` method.

Masses: the body's mass (density × enclosed volume) spread over the surface nodes by lumped area
(:func:`~tissuesim.solvers.mass_spring.surface_lumped_mass`). In the xpbd form they set the dynamics only.

Option ``prestrain`` (xpbd form, beyond the paper): the layer carries the tension of a stretched capsule, released at
the lips of a cut so that the wound gapes without a load (:mod:`tissuesim.layer.prestress`).

Option ``material`` (the hybrid's layer; xpbd form, implicit integrator, signed bending): ``"corotated"`` or
``"neo-hookean"`` solve the layer's nonlinear constraints as they are (:class:`~tissuesim.layer.finite_layer.FiniteLayer`:
Newton in ``solve_static``, a nonlinear implicit step with the constant rest factor in ``step``), so that turning
costs no energy; the layer has one constitutive form, and both names choose it (the volume's material is what they
tell apart).

Options ``gravity`` and ``attachments`` (:mod:`.gravity`, :mod:`.attachments`): where the layer is the body (the pbd
method) it carries the weight of its physical masses (m_i g, the ``mass_scale`` of the pbd form left out) and the
attachments' springs in its matrix (xpbd form, implicit integrator: the projections have no spring term); in the
hybrid, M_V carries both.

The ``pbd`` method prescribes the fixed nodes only; the hybrid adds its control nodes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..errors import SolverError, warn
from ..layer.kernels import pbd_step, xpbd_step
from ..fem.nonlinear import in_fractions
from .base import Solver
from .checks import flag, is_integer, positive_number
from .mass_spring import surface_lumped_mass

if TYPE_CHECKING:
    from ..layer.finite_layer import FiniteLayer
    from ..layer.static import LayerStatics
    from ..mesh.hybrid import HybridMesh

FORMS = ("xpbd", "pbd")
#: Time integrators of the xpbd form (the pbd form always steps with the paper's projection).
INTEGRATORS = ("implicit", "xpbd")
DEFAULT_INTEGRATOR = "implicit"
#: Said when the xpbd integrator is chosen. Its step drops XPBD's primal residual (the corrections are summed along
#: the gradients of successive iterates), so even a fully converged projection does not rest at the equilibrium:
#: measured on the cube (docs/solvers.md), projections converged to 1e-10 every step (70 to 6,653 sweeps, 4 to
#: 390 ms a step) still rested 19-44 % of the displacement apart across dt, density and E at fixed strain.
XPBD_OFF_EQUILIBRIUM = ("integrator='xpbd' does not rest at the layer's elastic equilibrium: its rest state moves "
                        "with dt, the masses, E at fixed strain and the sweeps (on the cube by 19-97 % of the "
                        "displacement for the hybrid, 0.8-6.9x for pbd); use it to look, and the default "
                        "integrator='implicit' for answers")
DEFAULT_FORM = "xpbd"
DEFAULT_ITERATIONS = 10
#: PBD-form stiffness where it is not the calibrated scalar: just below 1, because a full projection (k' = 1 in every
#: sweep) of a folded hinge diverges (measured: 20 N of pressure on the cube, positions ~1e77 m within 1000 steps).
DEFAULT_STIFFNESS = 0.99
#: Default per-step velocity damping (measured to settle quasi-static solves quickly, docs/solvers.md).
DEFAULT_DAMPING = 0.2


#: Constant-factor iterations per step of the finite-strain layer's implicit step.
LAYER_ITERATIONS = 1
#: Newton iterations of one finite-strain layer solve: where a strongly pulled layer wrinkles, its tangent is
#: indefinite and the definite part Newton falls back to converges linearly (measured: 30-50 iterations from 9 N
#: on the cube's top node).
LAYER_NEWTON = 200


class SurfaceLayerSolver(Solver):
    """A :class:`Solver` whose M_S is projected by the PBD/XPBD kernels; subclasses choose the prescribed nodes.

    Options (besides the common ones):
        form: ``"xpbd"`` (default, physical) or ``"pbd"`` (the paper's, dt- and mass-dependent).
        iterations: Gauss–Seidel sweeps per step (≥ 1) of the projection (pbd form, and the xpbd integrator).
        integrator: xpbd form's time step: ``"implicit"`` (default: implicit Euler of the layer linearised at rest,
            one back-substitution per step; it rests exactly at the static equilibrium for any dt and mass) or
            ``"xpbd"`` (Macklin et al.'s projection, nonlinear; it rests off the static answer by an amount that
            depends on dt, the masses and the sweeps, and says so with a TissuesimWarning; see docs/solvers.md).
        thickness_ratio: xpbd form: layer thickness over the local rest edge length β (dimensionless); default: the
            calibrated value of this method.
        stiffness: pbd form: stiffness coefficient k in (0, 1]; default: the calibrated value of this method, or
            :data:`DEFAULT_STIFFNESS`.
        mass_scale: pbd form: factor on the lumped node masses (> 0); default: the calibrated value of this
            method, or 1.
        prestrain: xpbd form, implicit integrator: in-plane prestrain ε of the surface in [0, 0.3] (default 0),
            beyond the paper: the
            layer carries the tension T = E h̄ ε/(1 − ν) of a stretched capsule, so that a cut gapes without a
            load (:mod:`tissuesim.layer.prestress`); an uncut surface does not move.
        signed_bending: use the signed bending angle (smooth at flat hinges, beyond the paper) instead of eq 10's
            unsigned one. Default: True in the xpbd form (its energy must be smooth for the static solver: eq 10's
            angle has a cusp at flat hinges, where its gradient is undefined), False in the paper's pbd form.

    Attributes:
        prescribed: ``(k,) int64`` M_S nodes set to ``targets`` each step (inverse mass 0).
        targets: ``(k, 3) float64`` their positions [m].
        mass: ``(n,) float64`` lumped node masses [kg].
        stretch_compliance, bend_compliance: xpbd form: ``(e,)`` [m/N] and ``(b,)`` [1/(N·m)] compliances.
        prestress_tension: T [N/m] of the prestrain (0 without one).
        stretch_multipliers, bend_multipliers: ``(e,)``, ``(b,) float64`` the XPBD Lagrange multipliers of the
            stretch [N] and bending [N·m] constraints (``integrator="xpbd"``; reset each step).
        rest_angle: ``(b,) float64`` [rad] each hinge's rest angle, signed or not as ``signed_bending``.
        predicted: ``(n, 3) float64`` [m] the step's predicted positions (eq 16), a workspace.
        built_statics: the layer's static solver once :meth:`statics` has built it, else None (a cut drops it).
    """

    cut_carrier = "tissuesim.solvers.surface_layer_cut:SurfaceLayerCut"
    # the prescribed nodes' targets, and what a window of prescribed nodes rebinds (the hybrid's near field)
    kept_arrays = (*Solver.kept_arrays, "targets")
    kept_values = (*Solver.kept_values, "prescribed", "inv_mass", "built_statics")
    #: Whether the layer stands for the whole body, so that it carries the weight (``gravity``) and the attachments
    #: (the pbd method); the hybrid's M_V carries them instead (:mod:`.gravity`).
    body_on_layer: ClassVar[bool] = True

    def __init__(self, hybrid_mesh: HybridMesh, *, form: str = DEFAULT_FORM, iterations: int = DEFAULT_ITERATIONS,
                 thickness_ratio: float | None = None, stiffness: float | None = None,
                 mass_scale: float | None = None, signed_bending: bool | None = None,
                 integrator: str = DEFAULT_INTEGRATOR, prestrain: float = 0.0, damping: float = DEFAULT_DAMPING,
                 **common: object):
        super().__init__(hybrid_mesh, damping=damping, **common)
        from ..layer.topology import SurfaceConstraints
        from . import calibrated as frozen

        signed_bending = None if signed_bending is None else flag("signed_bending", signed_bending)
        if form not in FORMS:
            raise SolverError(f"unknown form {form!r}; choose one of {', '.join(FORMS)}")
        if not is_integer(iterations) or iterations < 1:
            raise SolverError(f"iterations must be a positive integer, got {iterations!r}; pass a whole number, e.g. "
                              f"{DEFAULT_ITERATIONS}")
        if integrator not in INTEGRATORS:
            raise SolverError(f"unknown integrator {integrator!r}; choose one of {', '.join(INTEGRATORS)}")
        if self.material != "linear" and (form, integrator, signed_bending) not in (("xpbd", "implicit", None),
                                                                                     ("xpbd", "implicit", True)):
            chosen = f"form={form!r}" if form != "xpbd" else (
                f"integrator={integrator!r}" if integrator != "implicit" else "signed_bending=False")
            raise SolverError(f"material={self.material!r} needs the layer's xpbd form, implicit integrator and "
                              f"signed bending angle (its finite-strain solve has no other); drop {chosen}, or use "
                              "material='linear'")
        self.form = form
        self.integrator = integrator
        self.iterations = int(iterations)
        self.constraints = SurfaceConstraints.from_surface(hybrid_mesh.surface)
        self.signed_bending = (form == "xpbd") if signed_bending is None else signed_bending
        self.rest_angle = (self.constraints.rest_signed_angle if self.signed_bending
                            else self.constraints.rest_angle)
        option, value = frozen.option(self.name, form)
        given = {"thickness_ratio": thickness_ratio, "stiffness": stiffness, "mass_scale": mass_scale}
        allowed = {"xpbd": ("thickness_ratio",), "pbd": ("stiffness", "mass_scale")}[form]
        for name, number in given.items():
            if number is not None and name not in allowed:
                raise SolverError(f"{name} is not a parameter of the {form} form (it takes "
                                  f"{' and '.join(allowed)}); pick the form that has it")
        self.mass = surface_lumped_mass(hybrid_mesh.surface, self.density)
        self.thickness_ratio = self.stiffness = None
        self.mass_scale = 1.0
        if form == "xpbd":
            self._init_xpbd(value if thickness_ratio is None else thickness_ratio)
        else:
            defaults = {"stiffness": DEFAULT_STIFFNESS, "mass_scale": 1.0, option: value}
            self._init_pbd(defaults["stiffness"] if stiffness is None else stiffness,
                           defaults["mass_scale"] if mass_scale is None else mass_scale)
        self._init_prestress(prestrain)
        self.inv_mass = 1.0 / self.mass
        self.prescribed = np.zeros(0, dtype=np.int64)
        self.targets = np.zeros((0, 3))
        self.built_statics = None
        self.predicted = np.zeros_like(self.state.positions)
        # XPBD multipliers, reset each step (kernels.xpbd_step).
        self.stretch_multipliers = np.zeros(self.constraints.stretch_count)
        self.bend_multipliers = np.zeros(self.constraints.bending_count)
        if form == "xpbd" and integrator == "xpbd":
            warn(XPBD_OFF_EQUILIBRIUM)
        if self.body_on_layer and self.attachments and (form, integrator) != ("xpbd", "implicit"):
            raise SolverError(f"attachments on the {self.name} method need form='xpbd' with integrator='implicit' (the "
                              "defaults): the position projections have no spring term; drop form or integrator")

    def _init_xpbd(self, thickness_ratio) -> None:
        from ..layer.compliance import relative_shell_compliance, thickness_lengths

        self.thickness_ratio = positive_number("thickness_ratio", thickness_ratio, "1")
        c = self.constraints
        self.stretch_compliance, self.bend_compliance = relative_shell_compliance(
            c, youngs_modulus=self.youngs_modulus, poisson_ratio=self.poisson_ratio,
            thickness_ratio=self.thickness_ratio,
            thickness_length=thickness_lengths(self.hybrid, c.edges, c.rest_length))

    def _init_prestress(self, prestrain) -> None:
        from ..layer.prestress import check_prestrain, layer_tension

        self.prestrain = check_prestrain(prestrain)
        self._constant = (None, None)    # (the hybrid mesh, its constant forces (n, 3) [N] or None)
        self._applied, self._applied_stale = None, True     # forces + constant, redone when either changes
        thickness = (self.thickness_ratio or 0.0) * self.hybrid.built_edge_length     # the pbd form has none
        self.prestress_tension = layer_tension(self.prestrain, form=self.form, integrator=self.integrator,
                                               youngs_modulus=self.youngs_modulus, poisson_ratio=self.poisson_ratio,
                                               thickness=thickness)

    def applied_forces(self) -> np.ndarray:
        """``(n, 3) float64`` nodal forces [N] the layer is solved under: the external ``forces``, plus what never
        changes between cuts (:meth:`constant_forces`), added once per change of the load."""
        constant = self.constant_forces()
        if constant is None:
            return self.forces
        if self._applied_stale:
            if self._applied is None or self._applied.shape != constant.shape:
                self._applied = np.empty_like(constant)
            np.add(self.forces, constant, out=self._applied)
            self._applied_stale = False
        return self._applied

    def constant_forces(self) -> np.ndarray | None:
        """``(n, 3) float64`` [N] the layer's forces other than the loads, or None where there are none (the paper's
        model): with a prestrain, the tension a cut released at its lips
        (:func:`tissuesim.layer.prestress.release_forces`); where the layer is the body (:attr:`body_on_layer`), the
        weight of its physical masses and the attachments' pull at rest (:func:`.gravity.surface_constant_load`).
        Recomputed once per cut."""
        mesh, constant = self._constant
        if mesh is self.hybrid:
            return constant
        constant = None
        if self.prestress_tension != 0.0 and self.hybrid.info.get("cuts"):
            from ..layer.prestress import copy_origin, release_forces

            constant = release_forces(self.rest_positions, self.hybrid.surface.triangles,
                                      copy_origin(self.rest_positions), self.prestress_tension)
        if self.body_on_layer:
            from .gravity import surface_constant_load

            body = surface_constant_load(self, self.mass / self.mass_scale)
            constant = body if constant is None else (constant if body is None else constant + body)
        self._constant = (self.hybrid, constant)
        self._applied_stale = True
        return constant

    def _on_load_changed(self) -> None:
        self._applied_stale = True

    def _init_pbd(self, stiffness, mass_scale) -> None:
        self.stiffness = positive_number("stiffness", stiffness, "1", "0.5")
        if self.stiffness > 1.0:
            raise SolverError(f"stiffness must lie in (0, 1], got {stiffness!r}")
        self.mass_scale = positive_number("mass_scale", mass_scale, "1")
        self.mass = self.mass * self.mass_scale

    def _static_solve(self) -> int | None:
        """xpbd form: the layer's small-strain static equilibrium, one back-substitution
        (:mod:`tissuesim.layer.static`); pbd form: None (its equilibrium is only defined by its time stepping)."""
        if self.form != "xpbd":
            return None
        self._prepare_static()
        statics = self.statics()
        positions = self.state.positions
        positions[:] = self.rest_positions
        positions[self.prescribed] = self.targets
        moved = self.targets - self.rest_positions[self.prescribed]
        try:
            displacement = statics.displacement(self.applied_forces(), moved)
        except SolverError:
            self.static_fallbacks += 1  # a mechanism left by a cut: time stepping finds the resting state
            return None
        positions[statics.free_nodes] += displacement
        self.state.velocities[:] = 0.0
        if self.material == "linear":
            return 1
        self._finite_start(positions)
        try:
            return 1 + self._finite_static(statics, positions)
        except SolverError:
            # Newton found no way through (a layer pulled into a spike folds its hinges): the implicit steps,
            # whose rest state is this equilibrium, get there from the embedded start
            self.static_fallbacks += 1
            self._finite_start(positions)
            return None

    def _finite_static(self, statics, positions: np.ndarray) -> int:
        """The finite-strain layer's equilibrium, in place on ``positions``; returns the Newton iterations.

        From ``positions`` under the whole load first; where that does not converge, by continuation from rest: the
        load and the prescribed nodes' motion are applied in fractions, each solve starting from the last
        equilibrium, and a fraction that fails is halved (down to 1/64)."""
        try:
            return statics.static(positions, self.applied_forces(), self.targets, max_iterations=LAYER_NEWTON)
        except SolverError:
            pass
        forces, rest = self.applied_forces(), self.rest_positions
        start = rest[self.prescribed]
        positions[:] = rest
        counted = [0]

        def attempt(fraction: float) -> bool:
            trial = positions.copy()
            try:
                counted[0] += statics.static(trial, fraction * forces, start + fraction * (self.targets - start),
                                             max_iterations=LAYER_NEWTON)
            except SolverError:
                return False
            positions[:] = trial
            return True

        reached = in_fractions(attempt, first=0.25, smallest=1.0 / 64.0)
        if reached < 1.0:
            raise SolverError(f"the finite-strain layer's continuation stopped at {100 * reached:.3g} % of the load")
        return counted[0]

    def _finite_start(self, positions: np.ndarray) -> None:
        """Where the finite-strain layer's Newton starts, in place on ``positions`` ``(n, 3)`` [m]: the linear
        answer they hold, unless a subclass knows better."""

    def _implicit_step(self, dt: float) -> None:
        """Linear implicit Euler on the layer (:meth:`LayerStatics.implicit_step`); damping removes a fraction of the
        velocity before the step, as in the kernels."""
        s = self.state
        options = {} if self.material == "linear" else {"iterations": LAYER_ITERATIONS}
        self.statics().implicit_step(s.positions, s.velocities, self.rest_positions, self.applied_forces(),
                                     self.targets, self.mass, dt, self.damping, **options)

    def statics(self) -> LayerStatics | FiniteLayer:
        """The static solver of this layer and its prescribed nodes (built on first use: one sparse factorisation):
        :class:`~tissuesim.layer.static.LayerStatics` with the linear material, else the finite-strain layer."""
        if self.built_statics is None and self.material != "linear":
            from ..layer.finite_layer import FiniteLayer

            c = self.constraints
            self.built_statics = FiniteLayer(self.rest_positions, edges=c.edges, rest_length=c.rest_length,
                                        stretch_compliance=self.stretch_compliance, hinges=c.bending,
                                        rest_angle=self.rest_angle, bend_compliance=self.bend_compliance,
                                        prescribed=self.prescribed)
        if self.built_statics is None:
            self.built_statics = self._new_linear_statics()
        return self.built_statics

    def linear_statics(self) -> LayerStatics:
        """The layer's small-strain :class:`~tissuesim.layer.static.LayerStatics`: :meth:`statics` with the linear
        material; with a finite-strain one its tangent at rest, kept until the prescribed nodes or the surface
        change."""
        if self.material == "linear":
            return self.statics()
        kept = getattr(self, "_linear_statics", None)
        if (kept is None or kept.prescribed is not self.prescribed
                or kept.stiffness.shape[0] != 3 * len(self.rest_positions)):
            self._linear_statics = self._new_linear_statics()
        return self._linear_statics

    def _new_linear_statics(self):
        from ..layer.static import LayerStatics, layer_stiffness

        c = self.constraints
        stiffness = layer_stiffness(self.rest_positions, edges=c.edges, stretch_compliance=self.stretch_compliance,
                                    hinges=c.bending, bend_compliance=self.bend_compliance,
                                    signed_bending=self.signed_bending)
        if self.body_on_layer and self.attachments:     # k_i I₃ on each attached node's block
            from ..fem.springs import spring_stiffness

            nodes = self.attached_nodes
            stiffness = stiffness + spring_stiffness(len(self.rest_positions), nodes[:, None],
                                                     np.ones((nodes.size, 1)), self.attached_stiffness)
        return LayerStatics(stiffness, prescribed=self.prescribed)

    def _prepare_static(self) -> None:
        """Bring the prescribed nodes' ``targets`` up to date with the load (the hybrid's FEM part)."""

    def _set_prescribed(self, nodes: np.ndarray) -> None:
        """Prescribe ``nodes`` (M_S indices), at rest until the subclass moves ``targets``."""
        self.built_statics = None
        self.prescribed = np.ascontiguousarray(nodes, dtype=np.int64)
        self.targets = np.array(self.rest_positions[self.prescribed])
        self.inv_mass = 1.0 / self.mass
        self.inv_mass[self.prescribed] = 0.0

    def _step(self, dt: float) -> None:
        c, s = self.constraints, self.state
        if self.form == "xpbd" and self.integrator == "implicit":
            self._implicit_step(dt)
        elif self.form == "xpbd":
            xpbd_step(s.positions, s.velocities, self.predicted, self.inv_mass, self.applied_forces(),
                      self.prescribed, self.targets, dt, self.damping, self.iterations, c.edges, c.rest_length,
                      self.stretch_compliance, c.bending, self.rest_angle, self.bend_compliance,
                      self.stretch_multipliers, self.bend_multipliers, self.signed_bending)
        else:
            pbd_step(s.positions, s.velocities, self.predicted, self.inv_mass, self.applied_forces(), self.prescribed,
                     self.targets, dt, self.damping, self.iterations, c.edges, c.rest_length, self.stiffness,
                     c.bending, self.rest_angle, self.stiffness, self.signed_bending)
