"""Position-based surface methods: the shared surface layer, and the ``pbd`` method (the paper's PBD baseline).

The surface layer is M_S with a stretch constraint per edge (eq 8–9) and a bending constraint per interior edge
(eq 10–12), stepped by one Numba call per time step (:mod:`tissuesim.pbd.kernels`: eq 15, 16, prescribed nodes
as eq 17's first case, Gauss–Seidel projection, eq 18). Two forms (option ``form``):

* ``"xpbd"``: XPBD compliance from the material, the layer being a membrane + shell of thickness h
  (:mod:`tissuesim.pbd.compliance`); the one free scalar is ``thickness`` h [m]. Its equilibrium is that of a
  physical elastic layer and does not depend on dt (in the converged limit of the iterations);
* ``"pbd"`` (default): the paper's stiffness coefficients ``stiffness`` k in (0, 1], used for both stretch and
  bending (Müller's per-iteration correction makes it independent of the iteration count, not of dt).

Masses: the body's mass (density × enclosed volume) spread over the surface nodes by lumped area
(:func:`~tissuesim.solvers.mass_spring.surface_lumped_mass`), times ``mass_scale`` (default 1). The load enters by
eq 15 (v += f dt w) on the loaded node, so in the PBD form a load's effect per step is f dt² / m against a
projection of strength k ≤ 1: with physical masses and dt = 10 ms a 1 N load moves the loaded node ~0.2 m per
step, more than any k pulls back (the cube's top collapses: RMSE 186 mm at k → 1). The PBD form's effective
stiffness is therefore set by the mass scale, not by k.

The free scalar of each method and form (calibrated, :mod:`tissuesim.solvers.calibrated`):
pbd form: ``stiffness`` for hybrid (masses physical), ``mass_scale`` for pbd (with k = :data:`DEFAULT_STIFFNESS`); xpbd form: ``thickness``.

``pbd``: the fixed nodes are pinned at rest, every other node is projected; no FEM.
"""

from __future__ import annotations

import numpy as np

from ..errors import SolverError
from ..pbd.kernels import pbd_step, xpbd_step
from .base import Solver, positive_number, register
from .mass_spring import surface_lumped_mass

FORMS = ("xpbd", "pbd")
DEFAULT_FORM = "pbd"
DEFAULT_ITERATIONS = 10
#: PBD-form stiffness where it is not the calibrated scalar: just below 1, because a full projection (k' = 1 in every
#: sweep) of a folded hinge diverges (measured: 20 N of pressure on the cube, positions ~1e77 m within 1000 steps).
DEFAULT_STIFFNESS = 0.99
#: Default per-step velocity damping (measured to settle quasi-static solves quickly, docs/solvers.md).
DEFAULT_DAMPING = 0.2
#: The pbd method's default: settles 1 N on the cube in 104 steps (0.2: 157; 0.4: 286) and 20 N in 1261 (0.2: not
#: within 1500).
PBD_DAMPING = 0.1


class SurfaceLayerSolver(Solver):
    """A :class:`Solver` whose M_S is projected by the PBD/XPBD kernels; subclasses choose the prescribed nodes.

    Options (besides the common ones):
        form: ``"xpbd"`` or ``"pbd"``.
        iterations: Gauss–Seidel sweeps per step (≥ 1).
        thickness: XPBD layer thickness h [m]; default: the calibrated value of this method.
        stiffness: PBD stiffness coefficient k in (0, 1]; default: the calibrated value of this method, or
            :data:`DEFAULT_STIFFNESS`.
        mass_scale: factor on the lumped node masses (> 0); default: the calibrated value of this method, or 1.
        signed_bending: use the PBD kernels' signed bending angle (smooth at flat hinges, beyond the paper) instead
            of eq 10's unsigned one; default False (the paper's; see docs/solvers.md for the measurement).

    Attributes:
        prescribed: ``(k,) int64`` M_S nodes set to ``targets`` each step (inverse mass 0).
        targets: ``(k, 3) float64`` their positions [m].
    """

    def __init__(self, hybrid_mesh, *, form: str = DEFAULT_FORM, iterations: int = DEFAULT_ITERATIONS,
                 thickness: float | None = None, stiffness: float | None = None, mass_scale: float | None = None,
                 signed_bending: bool = False,
                 damping: float = DEFAULT_DAMPING, **common):
        super().__init__(hybrid_mesh, damping=damping, **common)
        from ..pbd.compliance import shell_compliance
        from ..pbd.topology import SurfaceConstraints

        if form not in FORMS:
            raise SolverError(f"unknown form {form!r}; choose one of {', '.join(FORMS)}")
        if int(iterations) != iterations or int(iterations) < 1:
            raise SolverError(f"iterations must be a positive integer, got {iterations!r}")
        self.form = form
        self.iterations = int(iterations)
        self.constraints = SurfaceConstraints.from_surface(hybrid_mesh.surface)
        self.signed_bending = bool(signed_bending)
        self._rest_angle = (self.constraints.rest_signed_angle if self.signed_bending
                            else self.constraints.rest_angle)
        from . import calibrated as frozen

        option, value = frozen.option(self.name, form)
        defaults = {"thickness": None, "stiffness": DEFAULT_STIFFNESS, "mass_scale": 1.0, option: value}
        thickness = defaults["thickness"] if thickness is None else thickness
        stiffness_default, stiffness = stiffness is None, defaults["stiffness"] if stiffness is None else stiffness
        mass_scale = defaults["mass_scale"] if mass_scale is None else mass_scale
        self.mass_scale = positive_number("mass_scale", mass_scale, "1")
        if form == "xpbd":
            if not stiffness_default:
                raise SolverError("stiffness is the pbd form's parameter; the xpbd form takes thickness [m]")
            self.thickness = positive_number("thickness", thickness, "m")
            self.stiffness = None
            self.stretch_compliance, self.bend_compliance = shell_compliance(
                self.constraints, youngs_modulus=self.youngs_modulus, poisson_ratio=self.poisson_ratio,
                thickness=self.thickness)
        else:
            if thickness is not None:
                raise SolverError("thickness is the xpbd form's parameter; the pbd form takes stiffness in (0, 1]")
            if not (np.isfinite(stiffness) and 0.0 < stiffness <= 1.0):
                raise SolverError(f"stiffness must lie in (0, 1], got {stiffness!r}")
            self.stiffness = float(stiffness)
            self.thickness = None
        self.mass = self.mass_scale * surface_lumped_mass(hybrid_mesh.surface, self.density)
        self.inv_mass = 1.0 / self.mass
        self.prescribed = np.zeros(0, dtype=np.int64)
        self.targets = np.zeros((0, 3))
        self._predicted = np.zeros_like(self.state.positions)
        self._lambda_stretch = np.zeros(self.constraints.stretch_count)
        self._lambda_bend = np.zeros(self.constraints.bending_count)

    def _set_prescribed(self, nodes: np.ndarray) -> None:
        """Prescribe ``nodes`` (M_S indices), at rest until the subclass moves ``targets``."""
        self.prescribed = np.ascontiguousarray(nodes, dtype=np.int64)
        self.targets = np.array(self.rest_positions[self.prescribed])
        self.inv_mass = 1.0 / self.mass
        self.inv_mass[self.prescribed] = 0.0

    def _step(self, dt: float) -> None:
        c, s = self.constraints, self.state
        if self.form == "xpbd":
            xpbd_step(s.positions, s.velocities, self._predicted, self.inv_mass, self.forces, self.prescribed,
                      self.targets, dt, self.damping, self.iterations, c.edges, c.rest_length,
                      self.stretch_compliance, c.bending, self._rest_angle, self.bend_compliance,
                      self._lambda_stretch, self._lambda_bend, self.signed_bending)
        else:
            pbd_step(s.positions, s.velocities, self._predicted, self.inv_mass, self.forces, self.prescribed,
                     self.targets, dt, self.damping, self.iterations, c.edges, c.rest_length, self.stiffness,
                     c.bending, self._rest_angle, self.stiffness, self.signed_bending)


@register("pbd")
class PBDSolver(SurfaceLayerSolver):
    """PBD on M_S alone: fixed nodes pinned at rest, every other node projected (see the module docstring)."""

    def __init__(self, hybrid_mesh, *, damping: float = PBD_DAMPING, **options):
        super().__init__(hybrid_mesh, damping=damping, **options)
        self._set_prescribed(self.fixed)
