"""The solver protocol shared by every method (its state: :mod:`.state`; its quasi-static solve:
:mod:`.quasi_static`; the registry: :mod:`.registry`).

A solver is built from a :class:`~tissuesim.mesh.hybrid.HybridMesh` (static data) plus keyword-only options; it
owns a :class:`State` (the mutable part: M_S positions and velocities) and its external loads (:mod:`.load_set`):
each a pin-head's force on one M_S node (§8.2), or spread over the nodes under a tip of radius R
(:mod:`tissuesim.loads`). Every method
exposes the same calls, so the experiments compare like with like:

* ``step(dt)`` advances one time step [s];
* ``set_load(node, force, radius=None)`` / ``clear_load()`` set or withdraw the external force [N] on an M_S node,
  or on the contact patch of radius R [m] around it; ``add_load`` / ``move_load`` / ``remove_load`` hold several at
  once, each by its handle;
* ``reset()`` returns to rest, at zero velocity and without load;
* ``solve_static(node, force, radius=None)`` returns the M_S positions at equilibrium: solved directly where the
  method has a static solver, else by stepping with damping until the surface settles.

Common options (keyword-only, the same for every method):

* ``youngs_modulus`` [Pa] = 5500 and ``poisson_ratio`` = 0.3: the paper's material (§8.2);
* ``fixed``: ``(k,)`` M_S vertex indices held at rest. Default: the model's bottom, the nodes with
  z ≤ :func:`~tissuesim.mesh.regions.bottom_height` of the M_S vertices. The FEM-based methods fix the volume
  nodes below the same height (default) or the volume nodes that coincide with the given M_S vertices;
* ``density`` [kg/m³] = 1000 (soft tissue is close to water); it sets node masses where a method has any;
* ``dt`` [s] = 0.01: the step that :meth:`Solver.step` and :meth:`Solver.solve_static` use when none is given
  (100 Hz, a haptics-free interactive rate); every time step lies in [:data:`~.checks.MIN_DT`, ∞);
* ``damping``: fraction of the velocity removed per step, in [0, 1);
* ``material``: ``"linear"`` (default: the paper's small-strain elasticity), ``"corotated"`` or ``"neo-hookean"``
  (finite strain, :mod:`tissuesim.fem.hyperelastic`), for the methods that list it in :attr:`Solver.materials`.
* ``gravity``: None (default: no gravity, the paper's) or the acceleration g ``(3,)`` [m/s²], e.g. (0, 0, −9.81):
  the body's weight ρ g, part of the model (not a load: :attr:`Solver.forces` stays the user's loads, and
  :meth:`Solver.reset` keeps it). Each method puts it where its mass is (:mod:`.gravity`);
* ``attachments``: elastic :class:`~.attachments.Attachment` springs (ligaments) from M_S vertices to fixed points,
  default none; they add stiffness, and with ``fixed`` they must hold the body (refused otherwise, see below).

The supports must hold the body: the fixed vertices plus the attached ones must leave no rigid motion of any
connected piece free (:func:`~.attachments.check_supports_hold`); every method refuses such supports up front with
a BoundaryConditionError. ``fixed`` may be empty where attachments hold the body.

``set_fixed_positions(x)`` moves the fixed set (finite-strain materials): a base that a grasper carries or turns.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BoundaryConditionError, SolverError, first_indices, warn
from ..mesh.regions import bottom_height, nodes_below
from ..fem.nonlinear import UnstableLoadError
from ..fem.rigid_modes import connected_pieces
from .card import MethodCard
from .load_patches import LoadPatches
from .attachments import attachment_springs, check_supports_hold
from .checks import fraction, gravity_vector, is_integer, node_set, positive_number, time_step
from .finite_strain import check_method_material, unstable_load_error, volume_range
from .load_set import Load, LoadSet
from .quasi_static import QuasiStaticSolve
from .report import SolveReport, validity_warning
from .snapshot import Snapshot
from .state import State, farthest_node

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh
    from .attachments import Attachment

DEFAULT_YOUNGS_MODULUS = 5500.0  # Pa, §8.2
DEFAULT_POISSON_RATIO = 0.3  # §8.2
DEFAULT_DENSITY = 1000.0  # kg/m³
DEFAULT_DT = 0.01  # s
#: A state has run away when a node lies farther than this many model sizes (the diagonal of M_S's rest bounding
#: box) from its rest position. Linear elasticity stops being valid near 0.1 sizes; the paper's largest load (20 N on
#: a cube corner) moves the fine FEM 35 sizes and the embedded surface 31, so 100 sizes is no tissue's answer, only
#: a blow-up (an unstable step: too large a dt, load or pin-head stiffness) or an absurd load.
RUNAWAY_SIZES = 100.0


class Solver(MethodCard, LoadPatches, LoadSet, QuasiStaticSolve, ABC):
    """Base class of every method: state, load and stepping (the quasi-static solve: :class:`QuasiStaticSolve`).

    Subclasses implement :meth:`_step` (one time step on ``self.state`` under ``self.forces``) and may override
    :meth:`_on_load_changed` (e.g. to redo the FEM part) and :meth:`_on_reset`.

    Attributes:
        hybrid: the static hybrid mesh.
        rest_positions: ``(n, 3) float64`` M_S rest positions [m] (read-only).
        fixed: ``(k,) int32`` sorted M_S vertex indices held at rest.
        gravity: ``(3,) float64`` the gravitational acceleration [m/s²] (read-only), or None.
        attachments: the :class:`~.attachments.Attachment` s; ``attached_nodes`` ``(p,) int64``,
            ``attached_stiffness`` ``(p,)`` [N/m] and ``attached_anchors`` ``(p, 3)`` [m]: their springs, one per
            attached node.
        forces: ``(n, 3) float64`` external nodal forces [N] on M_S, the sum of the loads (zero elsewhere);
            read-only to users, change it through the loads (:meth:`set_load`, :meth:`add_load`, ...).
        state: the :class:`State`.
        material: the constitutive model, ``"linear"`` or a finite-strain one (the ``material`` option);
            ``elasticity``: its :class:`~tissuesim.fem.material.Material` (E, ν and the Lamé constants).
        size: diagonal of M_S's rest bounding box [m].
        runaway_distance: :data:`RUNAWAY_SIZES` × ``size`` [m]: a node farther than this from rest, or a non-finite
            position, makes :meth:`step` and :meth:`solve_static` raise :class:`SolverError` (a blow-up).
        last_solve: :class:`SolveReport` of the last :meth:`solve_static`, or None.
        largest_displacement: largest node displacement from rest [m] after the last step or solve (0 at rest);
            :attr:`warning` says when it lies beyond linear elasticity.
        previous_positions: ``(n, 3) float64`` [m] the quasi-static loop's last positions, a workspace.
        patch_cache: ``{(node, R): (nodes, shares)}`` the contact patches found so far (:meth:`contact_patch`);
            ``lumped_area_cache``: ``(n,) float64`` [m²] the lumped areas they are weighted by, or None.
        active_cut_updater: the :class:`~.cut_carry.SolverCut` that carries this solver over cuts, from its first
            cut on (:func:`~.cut_carry.cut_updater`), else None.
    """

    def __init__(
        self,
        hybrid_mesh: HybridMesh,
        *,
        youngs_modulus: float = DEFAULT_YOUNGS_MODULUS,
        poisson_ratio: float = DEFAULT_POISSON_RATIO,
        fixed: ArrayLike | None = None,
        density: float = DEFAULT_DENSITY,
        dt: float = DEFAULT_DT,
        damping: float = 0.0,
        material: str = "linear",
        gravity: ArrayLike | None = None,
        attachments: Sequence[Attachment] = (),
    ):
        from ..fem.material import Material  # validates E and ν with MaterialError

        if not hasattr(hybrid_mesh, "surface") or not hasattr(hybrid_mesh, "volume"):
            raise SolverError(
                f"a solver needs a HybridMesh, got {type(hybrid_mesh).__name__}; build one with "
                "tissuesim.HybridMesh.build(surface)"
            )
        self.hybrid = hybrid_mesh
        self.elasticity = Material(youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio)  # checks both
        self.youngs_modulus = self.elasticity.youngs_modulus
        self.poisson_ratio = self.elasticity.poisson_ratio
        self.material = check_method_material(type(self), material)
        self.density = positive_number("density", density, "kg/m³")
        self.dt = dt
        self.damping = fraction("damping", damping)
        self.rest_positions = hybrid_mesh.surface.vertices  # read-only (SurfaceMesh freezes it)
        n = len(self.rest_positions)
        self.gravity = gravity_vector(gravity)
        if self.gravity is not None and self.gravity_caveat:
            warn(f"gravity on the {self.name} method: {self.gravity_caveat}")
        self.attachments = tuple(attachments) if isinstance(attachments, (tuple, list)) else attachments
        self.attached_nodes, self.attached_stiffness, self.attached_anchors = attachment_springs(
            self.attachments, self.rest_positions)
        self.fixed_from_height = fixed is None
        if fixed is None:
            self.fixed_height = bottom_height(self.rest_positions)
            self.fixed = nodes_below(self.rest_positions, self.fixed_height)
        else:
            self.fixed_height = None
            self.fixed = node_set("fixed", fixed, n, allow_empty=True)     # the check below says why not
        check_supports_hold(self.rest_positions, self._pieces(), self.fixed, self.attached_nodes, self.name)
        self.forces = np.zeros((n, 3))
        self._loads: list[Load] = []
        self.patch_cache: dict[tuple[int, float | None], tuple[np.ndarray, np.ndarray]] = {}
        self.lumped_area_cache: np.ndarray | None = None
        self.state = State.at_rest(self.rest_positions)
        self.previous_positions = np.array(self.rest_positions)  # workspace of the quasi-static loop
        extent = self.rest_positions.max(axis=0) - self.rest_positions.min(axis=0)
        self.size = float(np.linalg.norm(extent))
        self.runaway_distance = RUNAWAY_SIZES * self.size
        self.last_solve: SolveReport | None = None
        self.largest_displacement = 0.0
        self._range: tuple | None = None     # (volume array, its volume_range) of the state last measured
        #: Quasi-static solves whose static solver could not answer (a cut left a flap only inertia holds) and were
        #: finished by stepping.
        self.static_fallbacks = 0
        #: ``(k, 3) float64`` where :meth:`set_fixed_positions` put the fixed vertices [m] (at rest until then).
        self.fixed_positions = np.array(self.rest_positions[self.fixed])
        self.active_cut_updater = None

    # ----------------------------------------------------------------------------------------------- state access
    @property
    def warning(self) -> str | None:
        """A sentence when the state the last step or solve reached lies beyond what the material models, else
        None: what ``last_solve.warning`` says of a static answer, for the interactive path too. Linear elasticity:
        a node moved more than :data:`~.report.LINEAR_VALIDITY_FRACTION` of the model's size; a finite-strain
        material: an element crushed below :data:`~.report.FINITE_RANGE_J` of its volume."""
        volume = getattr(self, "volume_displacement", None)
        # once per measured state (a viewer asks every frame); a state put back brings its own volume array
        if self._range is None or self._range[0] is not volume:
            self._range = volume, volume_range(self)
        range_ = dict(self._range[1])
        return validity_warning(range_.pop("material"), self.largest_displacement, self.size, **range_)

    @property
    def node_count(self) -> int:
        """Number of M_S vertices n."""
        return len(self.rest_positions)

    @property
    def positions(self) -> np.ndarray:
        """``(n, 3) float64`` current M_S positions [m] (the live array: copy it to keep a snapshot)."""
        return self.state.positions

    @property
    def velocities(self) -> np.ndarray:
        """``(n, 3) float64`` current M_S velocities [m/s] (the live array)."""
        return self.state.velocities

    @property
    def displacements(self) -> np.ndarray:
        """``(n, 3) float64`` current positions minus rest positions [m] (a new array)."""
        return self.state.positions - self.rest_positions

    @property
    def dt(self) -> float:
        """The default time step [s] of :meth:`step` and :meth:`solve_static`; setting it checks it as they do."""
        return self._dt

    @dt.setter
    def dt(self, value: float) -> None:
        self._dt = time_step(value)

    # -------------------------------------------------------------------------------------------------- stepping
    def step(self, dt: float | None = None) -> None:
        """Advance one time step of ``dt`` [s] (default: the ``dt`` option).

        Raises SolverError when the state blew up (non-finite, or a node beyond :attr:`runaway_distance` from rest);
        :meth:`reset` then returns the solver to rest.
        """
        dt = self._check_dt(dt)
        try:
            self._step(dt)
        except UnstableLoadError as error:  # raised before anything moved
            raise unstable_load_error(self, error) from None
        self._check_blow_up(dt)

    def reset(self) -> None:
        """Back to rest: rest positions, zero velocities, no load, the fixed set at rest."""
        rest = self.rest_positions[self.fixed]
        if self.material != "linear" and not np.array_equal(self.fixed_positions, rest):
            self._move_fixed(rest)
            self.fixed_positions = np.array(rest)
        self._unloaded()

    def _unloaded(self) -> None:
        """Rest positions, zero velocities, no load; the fixed set stays where it was put."""
        self._withdraw_load()
        self.state.positions[:] = self.rest_positions
        self.state.velocities[:] = 0.0
        self.largest_displacement = 0.0
        # at rest (or carried rigidly with its base) no element is strained, whatever warm start a volume keeps
        self._range = getattr(self, "volume_displacement", None), {"material": self.material,
                                                                    "smallest_volume_ratio": 1.0, "crushed": 0}
        self._on_load_changed()
        self._on_reset()

    def set_fixed_positions(self, positions: ArrayLike) -> None:
        """Move the fixed set: ``positions`` ``(k, 3)`` [m] of the vertices in :attr:`fixed`, in that order (a base
        carried or turned by a grasper or retractor; the next step or static solve follows). A finite-strain
        ``material`` moves an unloaded body rigidly with a rigid motion of its base; linear elasticity would inflate
        it, so the linear material refuses (BoundaryConditionError)."""
        from .finite_strain import check_fixed_positions, check_support_motion

        if self.material == "linear":
            raise BoundaryConditionError(
                f"moving the fixed set needs a finite-strain material: linear elasticity inflates a turned body (by "
                f"about 1 + θ² at θ radians); build the {self.name} solver with material='corotated' or "
                "'neo-hookean'")
        if self.fixed.size == 0:
            raise BoundaryConditionError(f"the {self.name} solver has no fixed vertex to move (attachments hold it); "
                                         "give fixed= vertices to carry or turn")
        positions = check_fixed_positions(positions, self.fixed)
        check_support_motion(self.rest_positions[self.fixed], positions, self.size)
        self._move_fixed(positions)
        self.fixed_positions = positions

    def _move_fixed(self, positions: np.ndarray) -> None:
        """Subclasses with a finite-strain material carry the fixed set to ``positions`` ``(k, 3)`` [m]."""
        raise BoundaryConditionError(f"the {self.name} method cannot move its fixed set")

    def _check_blow_up(self, dt: float, when: str = "", *, linear: bool = False) -> None:
        """SolverError naming the cause and the fix when the state is non-finite or ran away (one O(n) pass).

        ``linear`` (a static linear solve, or a method whose step is one): only non-finite positions count, since a
        linear answer cannot run away; a large one is reported by :attr:`SolveReport.warning` instead."""
        node, distance = farthest_node(self.state.positions, self.rest_positions)
        self.largest_displacement = float(distance)
        self._range = None
        if distance <= self.runaway_distance or ((linear or self.static) and np.isfinite(distance)):
            return
        if np.isfinite(distance):
            what = (f"node {node} ran {distance:.3g} m from rest, more than {RUNAWAY_SIZES:g} times the model's "
                    f"size {self.size:.3g} m")
        else:
            what = f"node {node} has a non-finite position"
        load = "no load" if not self._loads else "; ".join(
            f"{np.linalg.norm(held.force):.3g} N at node {held.node}" for held in self._loads)
        if linear or self.static:  # no step to blame: the answer of a linear solve is out of float64's range
            raise SolverError(
                f"{self.name} solver's answer{when} is not finite ({what}) under {load}: the load is too large for "
                f"this material (E = {self.youngs_modulus:g} Pa) to give a representable displacement; lower the "
                "load, then call reset()")
        raise SolverError(
            f"{self.name} solver diverged{when} ({what}) under {load} with dt = {dt:g} s; the step is unstable for "
            "this load: lower dt, the load or the pin-head stiffness, or raise damping, then call reset()")

    # --------------------------------------------------------------------------------------- subclass interface
    @abstractmethod
    def _step(self, dt: float) -> None:
        """One time step of ``dt`` [s] (already validated) on ``self.state`` under ``self.forces``."""

    def _on_load_changed(self) -> None:
        """Called after the load changed (set, cleared, reset)."""

    @classmethod
    def static_by_default(cls) -> bool:
        """Whether a step of the method built with its default options is the static answer (a method whose options
        decide it, as the hybrid's ``element``, makes :attr:`static` a property: False here)."""
        return cls.static is True

    @classmethod
    def solves_statics(cls) -> bool:
        """Whether :meth:`solve_static` solves the equilibrium directly (exact to round-off) instead of stepping
        until the surface settles."""
        return cls.static_by_default() or cls._static_solve is not Solver._static_solve

    def _static_solve(self) -> int | None:
        """Put ``self.state`` at the static equilibrium under the current load and return the iterations taken,
        or None where the method has no static solver (``solve_static`` then steps to equilibrium)."""
        return None

    def _on_reset(self) -> None:
        """Called after :meth:`reset` restored rest positions and zero velocities."""

    def snapshot(self) -> Snapshot:
        """The state a step reads (:class:`~.snapshot.Snapshot`): :meth:`restore` puts it back, bit for bit."""
        return Snapshot(self)

    def restore(self, snapshot: Snapshot) -> None:
        """Put back the state of ``snapshot``: the next steps equal a twin's that never did the work between."""
        snapshot.restore(self)

    def before_first_cut(self) -> None:
        """Called by the scalpel before the first cut of this solver's mesh (the hybrid's near field, whose fine
        volume is not cut, switches off)."""

    # ---------------------------------------------------------------------------------------------- validation
    def _check_node(self, node) -> int:
        if not is_integer(node):
            raise SolverError(f"load node must be an integer vertex index, got {node!r}")
        index = int(node)
        if not 0 <= index < self.node_count:
            raise SolverError(
                f"load node {node!r} is outside the surface's vertices 0..{self.node_count - 1}; pick an M_S "
                "vertex index (PinHead.grab snaps a point to one)"
            )
        return index

    def attachment_forces(self) -> np.ndarray:
        """``(p, 3) float64`` the force [N] each attachment spring exerts on the body now, k_i (a_i − x_i), one row
        per attached node (attachments in turn, as :attr:`attached_nodes`); their sum balances the weight and the
        loads that the fixed vertices do not carry."""
        return self.attached_stiffness[:, None] * (self.attached_anchors - self._attached_positions())

    def _pieces(self) -> np.ndarray:
        """``(n,) int`` the piece of the body each M_S vertex belongs to (what the supports must hold, each piece by
        itself): the surface's connected pieces; a method with a volume labels each vertex by the volume's piece
        that carries it."""
        return connected_pieces(self.hybrid.surface.triangles, self.node_count)[1]

    def _attached_positions(self) -> np.ndarray:
        """``(p, 3)`` where the attachment springs hold the body now [m]: the attached M_S vertices."""
        return self.state.positions[self.attached_nodes]

    def _check_dt(self, dt) -> float:
        return self.dt if dt is None else time_step(dt)

    def surface_to_volume(self) -> np.ndarray:
        """``(n,) int64`` the volume node at each M_S vertex (−1: none): the control nodes' M_V nodes, of the mesh
        as it is now (a cut adds vertices that are none and releases control nodes)."""
        mapping = np.full(self.node_count, -1, dtype=np.int64)
        mapping[self.hybrid.control] = self.hybrid.control_volume
        return mapping

    def fixed_volume_nodes(self, volume_points: np.ndarray, surface_to_volume: np.ndarray | None) -> np.ndarray:
        """``(k,) int32`` fixed nodes of a volume mesh with nodes ``volume_points`` ``(N, 3)`` [m].

        With the default bottom: every volume node at or below the same height as the M_S bottom. With explicit
        M_S ``fixed`` vertices: the volume nodes that coincide with them, ``surface_to_volume`` mapping M_S
        vertex → volume node (−1 where none).
        """
        if self.fixed_from_height:
            return nodes_below(volume_points, self.fixed_height)
        mapped = surface_to_volume[self.fixed]
        mapped = np.unique(mapped[mapped >= 0]).astype(np.int32)
        if mapped.size == 0 and not self.attachments:
            raise BoundaryConditionError(
                f"none of the {self.fixed.size} fixed M_S vertices (first: {first_indices(self.fixed)}) is a node "
                f"of the {self.name} solver's volume mesh, so the volume would float freely; include control "
                "nodes (hybrid_mesh.control) in `fixed`, or leave `fixed` at its default (the bottom)"
            )
        return mapped
