"""A validated binding of the step kernels to one surface: check everything once, then ``step(dt)`` is one call.

Solvers (``solvers/hybrid.py``, ``solvers/surface_layer.py``) keep their state arrays and hand them to a
:class:`SurfaceStepper`, which checks shapes, dtypes and ranges at setup and then calls
:func:`~tissuesim.layer.kernels.pbd_step` or :func:`~tissuesim.layer.kernels.xpbd_step` on the same arrays each step,
in place. Write into the bound arrays (``positions[:] = ...``), never rebind them, or call :meth:`bind` again.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SolverError, first_indices
from .kernels import pbd_step, xpbd_step
from .topology import SurfaceConstraints

FORMS = ("pbd", "xpbd")


def _state_array(name: str, value, n: int) -> np.ndarray:
    if not isinstance(value, np.ndarray) or value.dtype != np.float64 or value.shape != (n, 3) \
            or not value.flags.c_contiguous or not value.flags.writeable:
        shape = getattr(value, "shape", None)
        dtype = getattr(value, "dtype", type(value).__name__)
        raise SolverError(f"{name} must be a writeable C-contiguous (n, 3) float64 array with n = {n} surface "
                          f"nodes, got shape {shape}, dtype {dtype}; allocate it with np.zeros(({n}, 3))")
    return value


class SurfaceStepper:
    """Eq 15–18 time stepping of a fine surface's stretch + bending constraints (paper §6.5), PBD or XPBD.

    Args:
        constraints: the surface's :class:`SurfaceConstraints`.
        positions, velocities: ``(n, 3) float64`` C-contiguous state arrays [m], [m/s], updated in place by step.
        inv_mass: ``(n,) float64`` inverse node masses [1/kg], ≥ 0 (0 = never moved by projection). Copied; the
            prescribed nodes' entries are zeroed in the copy.
        form: ``"pbd"`` (stiffness coefficients, the paper) or ``"xpbd"`` (compliance, Macklin et al. 2016).
        iterations: Gauss–Seidel sweeps per step, ≥ 1.
        damping: velocity damping factor per step in [0, 1) (see :mod:`tissuesim.layer.kernels`).
        k_stretch, k_bend: PBD stiffness coefficients in [0, 1] (form "pbd").
        stretch_compliance: ``(e,)`` or scalar α [m/N] ≥ 0 (form "xpbd"; e.g. from
            :func:`tissuesim.layer.compliance.shell_compliance`).
        bend_compliance: ``(b,)`` or scalar α [1/(N·m)] ≥ 0 (form "xpbd").
        prescribed: ``(k,)`` node indices whose positions are set from :attr:`targets` each step (eq 17).
        forces: optional ``(n, 3) float64`` external-force array [N] to bind; by default one is allocated (zeros).
        signed_bending: False (the paper's eq 10) or True (signed angle, smooth at flat hinges; beyond the paper).

    Attributes:
        forces: ``(n, 3) float64`` external force per node [N]; write into it between steps.
        targets: ``(k, 3) float64`` prescribed positions [m] for the next step, rows in ``prescribed`` order;
            initialised to the nodes' current positions.
        prescribed: ``(k,) int64`` the prescribed node indices.
    """

    def __init__(self, constraints: SurfaceConstraints, *, positions: np.ndarray, velocities: np.ndarray,
                 inv_mass: ArrayLike, form: str = "pbd", iterations: int = 10, damping: float = 0.0,
                 k_stretch: float = 1.0, k_bend: float = 1.0, stretch_compliance: ArrayLike | None = None,
                 bend_compliance: ArrayLike | None = None, prescribed: ArrayLike = (),
                 forces: np.ndarray | None = None, signed_bending: bool = False):
        if not isinstance(constraints, SurfaceConstraints):
            raise SolverError(f"constraints must be a SurfaceConstraints, got {type(constraints).__name__}; "
                              "build one with SurfaceConstraints.from_surface(surface)")
        self.constraints = constraints
        self.n = constraints.vertex_count
        if form not in FORMS:
            raise SolverError(f"unknown PBD form {form!r}; choose one of {', '.join(FORMS)}")
        self.form = form
        self.signed_bending = bool(signed_bending)
        if self.signed_bending and constraints.rest_signed_angle is None:
            raise SolverError("signed_bending needs constraints.rest_signed_angle; build the constraints with "
                              "SurfaceConstraints.from_surface(surface)")
        self._rest_bend = constraints.rest_signed_angle if self.signed_bending else constraints.rest_angle
        self.bind(positions, velocities, forces)
        self.set_iterations(iterations)
        self.set_damping(damping)
        self.set_stiffness(k_stretch=k_stretch, k_bend=k_bend)
        self.set_compliance(stretch_compliance if stretch_compliance is not None else 0.0,
                            bend_compliance if bend_compliance is not None else 0.0)
        if form == "xpbd" and (stretch_compliance is None or bend_compliance is None):
            raise SolverError("form 'xpbd' needs stretch_compliance and bend_compliance (e.g. from "
                              "tissuesim.layer.compliance.shell_compliance(constraints, thickness=h))")
        self._inv_mass = self._check_inv_mass(inv_mass)
        self._lambda_stretch = np.zeros(constraints.stretch_count)
        self._lambda_bend = np.zeros(constraints.bending_count)
        self._predicted = np.zeros((self.n, 3))
        self.set_prescribed(prescribed)

    # ------------------------------------------------------------ setup (validated here, once)

    def bind(self, positions: np.ndarray, velocities: np.ndarray, forces: np.ndarray | None = None) -> None:
        """Bind the state arrays (checked here, not per step). ``forces=None`` keeps (or allocates) our own."""
        self.positions = _state_array("positions", positions, self.n)
        self.velocities = _state_array("velocities", velocities, self.n)
        if positions is velocities:
            raise SolverError("positions and velocities must be different arrays")
        if forces is not None:
            self.forces = _state_array("forces", forces, self.n)
        elif getattr(self, "forces", None) is None:
            self.forces = np.zeros((self.n, 3))

    def _check_inv_mass(self, inv_mass) -> np.ndarray:
        w = np.array(inv_mass, dtype=np.float64)
        if w.shape != (self.n,):
            raise SolverError(f"inv_mass must have shape ({self.n},), one inverse mass [1/kg] per surface node, "
                              f"got {w.shape}")
        bad = np.flatnonzero(~np.isfinite(w) | (w < 0.0))
        if bad.size:
            raise SolverError(f"{bad.size} inverse masses are negative or not finite (first nodes: "
                              f"{first_indices(bad)}); use 1/mass, or 0 for a node projection must not move")
        return w

    def set_prescribed(self, nodes: ArrayLike) -> None:
        """Prescribe ``(k,)`` nodes (eq 17 first case); :attr:`targets` restarts at their current positions."""
        nodes = np.asarray(nodes)
        if nodes.size == 0:
            nodes = np.zeros(0, dtype=np.int64)
        if nodes.ndim != 1 or not np.issubdtype(nodes.dtype, np.integer):
            raise SolverError(f"prescribed nodes must be a 1-D integer array, got shape {nodes.shape}, "
                              f"dtype {nodes.dtype}")
        bad = np.flatnonzero((nodes < 0) | (nodes >= self.n))
        if bad.size:
            raise SolverError(f"{bad.size} prescribed node indices are outside 0..{self.n - 1} (first: "
                              f"{first_indices(nodes[bad])})")
        if np.unique(nodes).size != nodes.size:
            raise SolverError("prescribed node indices repeat; give each node once")
        self.prescribed = np.ascontiguousarray(nodes, dtype=np.int64)
        self.targets = self.positions[self.prescribed].copy()
        self._weights = self._inv_mass.copy()
        self._weights[self.prescribed] = 0.0

    def set_iterations(self, iterations: int) -> None:
        if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) or iterations < 1:
            raise SolverError(f"iterations must be an integer ≥ 1, got {iterations!r}")
        self.iterations = int(iterations)

    def set_damping(self, damping: float) -> None:
        if not (np.isfinite(damping) and 0.0 <= damping < 1.0):
            raise SolverError(f"damping must lie in [0, 1), got {damping!r}")
        self.damping = float(damping)

    def set_stiffness(self, *, k_stretch: float, k_bend: float) -> None:
        """PBD stiffness coefficients in [0, 1] (form "pbd")."""
        for name, k in (("k_stretch", k_stretch), ("k_bend", k_bend)):
            if not (np.isfinite(k) and 0.0 <= k <= 1.0):
                raise SolverError(f"{name} must lie in [0, 1], got {k!r}")
        self.k_stretch, self.k_bend = float(k_stretch), float(k_bend)

    def set_compliance(self, stretch: ArrayLike, bend: ArrayLike) -> None:
        """XPBD compliances: stretch ``(e,)`` or scalar [m/N], bending ``(b,)`` or scalar [1/(N·m)], all ≥ 0."""
        c = self.constraints
        out = []
        for name, value, count in (("stretch_compliance", stretch, c.stretch_count),
                                   ("bend_compliance", bend, c.bending_count)):
            a = np.array(np.broadcast_to(np.asarray(value, dtype=np.float64), (count,))
                         if np.ndim(value) == 0 else np.asarray(value, dtype=np.float64))
            if a.shape != (count,):
                raise SolverError(f"{name} must be a scalar or have shape ({count},), got {a.shape}")
            bad = np.flatnonzero(~np.isfinite(a) | (a < 0.0))
            if bad.size:
                raise SolverError(f"{bad.size} {name} values are negative or not finite (first constraints: "
                                  f"{first_indices(bad)})")
            out.append(np.ascontiguousarray(a))
        self.stretch_compliance, self.bend_compliance = out

    # ------------------------------------------------------------ the hot path

    def step(self, dt: float) -> None:
        """Advance one time step of ``dt`` [s] (eq 15–18): one kernel call, nothing allocated."""
        if not dt > 0.0:
            raise SolverError(f"time step must be positive, got {dt!r}")
        dt = float(dt)
        c = self.constraints
        if self.form == "pbd":
            pbd_step(self.positions, self.velocities, self._predicted, self._weights, self.forces, self.prescribed,
                     self.targets, dt, self.damping, self.iterations, c.edges, c.rest_length, self.k_stretch,
                     c.bending, self._rest_bend, self.k_bend, self.signed_bending)
        else:
            xpbd_step(self.positions, self.velocities, self._predicted, self._weights, self.forces,
                      self.prescribed, self.targets, dt, self.damping, self.iterations, c.edges, c.rest_length,
                      self.stretch_compliance, c.bending, self._rest_bend, self.bend_compliance,
                      self._lambda_stretch, self._lambda_bend, self.signed_bending)

    @property
    def weights(self) -> np.ndarray:
        """``(n,) float64`` inverse masses the kernels use [1/kg] (prescribed nodes 0); read-only view."""
        view = self._weights.view()
        view.flags.writeable = False
        return view
