"""A grasper: jaws that take hold of a patch of the surface and carry it rigidly, the force being the output.

    grasper = Grasper(solver, radius=0.004)             # jaws 4 mm across each way
    grasper.grab(point)                                 # holds the surface vertices within 4 mm of the point
    grasper.move_to(point + [0, 0, 0.01])               # the held patch 10 mm up, at static equilibrium
    grasper.force, grasper.torque                       # the tissue's reaction on the jaws [N], [N·m]
    grasper.settle(point, rotation=turn)                # a frame's worth, for a viewer or a haptic loop
    grasper.release()

What the pin-head (§8.2, eq 24) does by a spring to the cursor, the grasper does exactly: each held vertex i goes
where the jaws carry it, t_i = p + R (X_i − p₀) (p the jaws' position, R their rotation, X_i and p₀ where the vertex
and the jaws were at the grab), as a prescribed displacement. Every method takes loads, not prescribed
displacements, so the grasper finds the nodal forces f_i that put the held vertices on their targets: the Lagrange
multipliers of the constraints x_i = t_i, i.e. the reactions. It iterates

    f ← f + J⁻¹ (t − x(f)),    J ≈ ∂x/∂f (3k × 3k),

each iteration one static solve of the solver with the forces as its own loads (beside any other tool's), until
every held vertex is within :attr:`Grasper.tolerance` of its target. J starts from the solver's own compliance where
it has one (``point_compliance``: the fem reference, the embedded surface, the hybrid with either M_V; exact with the
linear material, so one iteration solves it), else from a model (a method's ``compliance_model``, or an elastic
half-space of the solver's E and ν: Boussinesq's normal compliance on each axis,
:func:`~tissuesim.tools.probe_complementarity.half_space_compliance`) that a short first step sizes, and learns
from each solve by Broyden's update; it is kept while the jaws hold, so a dragged grasper costs one or two solves a
frame. The converged answer is the solver's equilibrium with those vertices prescribed: it does not depend on J, dt,
the masses or the iteration caps; J sets only how fast it is reached.

Refused with a reason (and then nothing changes: the solver's state and loads, and the grasper's own, are as
before): jaws farther than their radius from the surface, a patch with a fixed vertex in it (the support holds it
already), a vertex another grasper holds, and a motion under which a finite-strain volume inverts (J = det F ≤ 0).
"""

from __future__ import annotations

import itertools
import weakref
from typing import TYPE_CHECKING

import numpy as np

from ..errors import BoundaryConditionError, SolverError, first_indices
from .probe_complementarity import half_space_compliance
from .grasp_model import checked_rotation, fitted_model, follows_by_updates, largest_miss, solver_compliance
from ..solvers.checks import checked_point, positive_number, whole_count
from ..solvers.load_set import VertexLoads
from ..solvers.snapshot import Snapshot, refusal_restores
from .base import Tool

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..solvers.base import Solver

#: Default tolerance: the largest distance of a held vertex from its target, as a fraction of the jaws' radius.
TOLERANCE_FRACTION = 1e-3
DEFAULT_MAX_ITERATIONS = 60
#: :meth:`Grasper.settle`'s default: the iterations one frame may spend.
FRAME_ITERATIONS = 8
DEFAULT_MAX_STEPS = 20000
#: The first step of a model not yet sized by a solve goes this fraction of the Newton step: a coarse model can be
#: tens of times stiffer than the tissue (the hybrid's layer between control nodes), and the full step would throw
#: the patch that many times too far.
FIRST_STEP = 0.1
#: How many refused solves in a row are retried with a quarter of the step before the refusal is the answer.
RETRIES = 3
#: :meth:`Grasper.update` moves the forces this fraction of the Newton change: the step after it goes only part of
#: the way to the equilibrium, so a full change would overshoot (the probe's interactive update does the same).
RELAXATION = 0.3
#: Each iteration's solve goes this fraction of the tolerance close to equilibrium (a method that steps to it).
SOLVE_FRACTION = 0.1
#: ... measured as the motion per this much simulated time [s] (the default step).
SOLVE_TIME = 0.01

#: The graspers holding each solver's vertices: two jaws may not prescribe the same vertex, and their forces are
#: solved together.
_HOLDERS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: Numbers each grasper in the order made (a group is solved oldest first, whichever of them moves).
_SERIALS = itertools.count()
#: Singular values of J below this fraction of its largest count as zero in the least-squares change.
SINGULAR = 1e-10


class Grasper(Tool):
    """Jaws that hold a surface patch and carry it rigidly (see the module docstring).

    Args:
        solver: any :class:`~tissuesim.solvers.base.Solver`.
        radius: the jaws' reach [m]: :meth:`grab` holds the surface vertices within it of the grab point.
        tolerance: the largest distance [m] of a held vertex from its target that a static move accepts; default
            :data:`TOLERANCE_FRACTION` × ``radius``.

    Attributes:
        held: ``(k,) int64`` the held M_S vertices (empty before a grab).
        position: ``(3,) float64`` the jaws' position [m], or None (holding nothing).
        rotation: ``(3, 3) float64`` the jaws' rotation since the grab.
        iterations, steps, residual: of the last move: iterations, solver steps, and the largest distance of a
            held vertex from its target [m].
    """

    kind = "grasper"
    needs = "loads on surface vertices and a static solve"

    def __init__(self, solver: Solver, *, radius: float, tolerance: float | None = None):
        for needed in ("positions", "rest_positions", "add_load", "move_load", "remove_load", "loads",
                       "solve_static"):
            if not hasattr(solver, needed):
                raise SolverError(f"Grasper needs a solver (from tissuesim.make_solver), got {type(solver).__name__}")
        self._solver = solver
        self.radius = positive_number("grasper radius", radius, "m")
        self.tolerance = (TOLERANCE_FRACTION * self.radius if tolerance is None
                          else positive_number("grasper tolerance", tolerance, "m"))
        self.held = np.zeros(0, dtype=np.int64)
        self.position: np.ndarray | None = None
        self.rotation = np.eye(3)
        self.iterations, self.steps, self.residual = 0, 0, 0.0
        self._grip = np.zeros((0, 3))          # the held vertices about the jaws at the grab [m]
        self._jacobian: np.ndarray | None = None
        self._learned: np.ndarray | None = None  # J once a solve has scaled it (None: the model's, unscaled)
        self._key = None                        # the surface and the group the Jacobian belongs to
        self._seen = 0                          # the vertex count at the last look (a cut appends vertices)
        self._serial = next(_SERIALS)
        self._loads = VertexLoads(solver)

    # ------------------------------------------------------------------------------------------------ reading
    @property
    def solver(self) -> Solver:
        """The solver the jaws act on (fixed: make a new grasper for another)."""
        return self._solver

    @property
    def holding(self) -> bool:
        return self.position is not None

    @property
    def force(self) -> np.ndarray:
        """``(3,) float64`` the tissue's reaction on the jaws [N]: minus the sum of their forces on the tissue."""
        return -self._loads.total()

    @property
    def torque(self) -> np.ndarray:
        """``(3,) float64`` the tissue's reaction torque on the jaws about :attr:`position` [N·m]."""
        if not self.holding:
            return np.zeros(3)
        arms = self.solver.positions[self.held] - self.position
        return -np.cross(arms, self._loads.at(self.held)).sum(axis=0)

    def targets(self) -> np.ndarray:
        """``(k, 3) float64`` where the jaws put the held vertices now [m]."""
        self._require_holding()
        return self.position + self._grip @ self.rotation.T

    # ----------------------------------------------------------------------------------------------- driving
    def grab(self, point: ArrayLike) -> np.ndarray:
        """Take hold of the surface vertices within :attr:`radius` of ``point`` ``(3,)`` [m] at the current
        positions, where they are (a grab moves nothing); returns them ``(k,) int64``. A grasper that held a
        patch lets it go first. Refused (nothing changes) where no vertex lies within reach, where the patch
        includes a fixed vertex or one another grasper holds."""
        point = checked_point(point, name="the grasp point").copy()
        positions = self.solver.positions
        distance = np.linalg.norm(positions - point, axis=1)
        held = np.flatnonzero(distance <= self.radius).astype(np.int64)
        if held.size == 0:
            nearest = int(np.argmin(distance))
            raise SolverError(
                f"nothing to grasp: the nearest surface vertex ({nearest}) is {distance[nearest]:.4g} m from the "
                f"jaws, beyond their radius {self.radius:.4g} m; put the grasp point on the surface or use larger "
                "jaws")
        fixed = np.intersect1d(held, self.solver.fixed)
        if fixed.size:
            raise BoundaryConditionError(
                f"the jaws would hold {fixed.size} fixed vertices (first: {first_indices(fixed)}), which the support "
                "holds already and no grasper can move; grasp farther from the support or with smaller jaws")
        taken = np.intersect1d(held, _held_by_others(self))
        if taken.size:
            raise SolverError(
                f"{taken.size} of the vertices under the jaws (first: {first_indices(taken)}) are held by another "
                "grasper; two jaws cannot prescribe one vertex: release the other or grasp elsewhere")
        self.release()
        self.held, self.position, self.rotation = held, point, np.eye(3)
        self._grip = positions[held] - point
        self._seen = self.solver.node_count
        self._jacobian, self._learned, self.residual = None, None, 0.0
        _HOLDERS.setdefault(self.solver, weakref.WeakSet()).add(self)
        return held.copy()

    def move_to(self, position: ArrayLike, rotation: ArrayLike | None = None, *,
                max_iterations: int = DEFAULT_MAX_ITERATIONS, max_steps: int = DEFAULT_MAX_STEPS) -> np.ndarray:
        """Carry the held patch to the jaws at ``position`` ``(3,)`` [m] turned by ``rotation`` ``(3, 3)`` (a
        proper rotation matrix about the jaws, from the grab; None: as they are) and return :attr:`force`, at the
        static equilibrium with every held vertex within :attr:`tolerance` of its target and every other load
        acting. Raises SolverError when ``max_iterations`` pass first, or where the motion inverts a finite-strain
        volume; a refused move changes nothing."""
        max_iterations = whole_count("max_iterations", max_iterations)
        max_steps = whole_count("max_steps", max_steps)
        with refusal_restores(self, solving=True):
            self._place(position, rotation)
            if not self._iterate(max_iterations, max_steps):
                raise SolverError(
                    f"the grasper did not reach its targets in {max_iterations} iterations (a held vertex is "
                    f"{self.residual:.3g} m from its target, tolerance {self.tolerance:.3g} m); nothing was "
                    "changed; raise max_iterations or the tolerance")
        return self.force

    def settle(self, position: ArrayLike | None = None, rotation: ArrayLike | None = None, *,
               max_iterations: int = FRAME_ITERATIONS) -> bool:
        """A frame's worth of :meth:`move_to`: the jaws to ``position`` (None: where they are) and ``rotation``,
        then at most ``max_iterations`` iterations, leaving the solver at its equilibrium under the last forces;
        returns whether the held vertices reached their targets (if not, the next call goes on from there). Refused
        as :meth:`move_to`, changing nothing."""
        max_iterations = whole_count("max_iterations", max_iterations)
        self._require_holding()
        with refusal_restores(self, solving=True):
            self._place(self.position if position is None else position, rotation)
            return self._iterate(max_iterations, DEFAULT_MAX_STEPS)

    def update(self, position: ArrayLike | None = None, rotation: ArrayLike | None = None) -> None:
        """One force update toward the jaws at ``position`` (None: where they are) and ``rotation``, from the
        current positions and without a solve (the caller's ``solver.step()`` follows): :data:`RELAXATION` of the
        Newton change with J as it is (a frame's positions are no equilibrium to learn from). What a viewer or a
        haptic loop calls each frame on a method whose step is not a static solve but which has its compliance
        (``point_compliance``: a finite-strain hybrid, whose static solve takes seconds at 10k vertices): no frame
        waits, and the patch reaches its jaws over a few frames. Refused as :meth:`move_to`, changing nothing."""
        self._require_holding()
        with refusal_restores(self, solving=False):
            self._place(self.position if position is None else position, rotation)
            group = self._group()
            error, misses = _errors(group)
            self.residual = largest_miss(error)
            if misses > 1.0:
                change = np.linalg.lstsq(self._current_jacobian(group), error.ravel(), rcond=SINGULAR)[0]
                _add_forces(group, RELAXATION * change)

    def follow(self, position: ArrayLike | None = None, rotation: ArrayLike | None = None) -> None:
        """A frame's worth of following the jaws, whichever way keeps the frame short: :meth:`settle` (the patch on
        its jaws at the end of the frame), or on a finite-strain method whose step is no static solve but which has
        its compliance (the hybrid, whose static solve takes seconds at 10k vertices) :meth:`update` (the patch
        reaches its jaws over a few frames). The caller steps the solver after it."""
        if follows_by_updates(self.solver):
            self.update(position, rotation)
        else:
            self.settle(position, rotation)

    def release(self) -> None:
        """Let go: the jaws' forces leave the solver (other loads act on); nothing is held."""
        self._loads.set(np.zeros(0, dtype=np.int64), np.zeros((0, 3)))
        holders = _HOLDERS.get(self.solver)
        if holders is not None:
            holders.discard(self)
        self.held, self.position, self.rotation = np.zeros(0, dtype=np.int64), None, np.eye(3)
        self._grip, self._jacobian, self._learned = np.zeros((0, 3)), None, None

    # the Tool protocol: a press takes hold, a move carries the jaws a frame's worth, their turn kept
    def press(self, point: ArrayLike) -> np.ndarray:
        """:meth:`grab` at ``point`` [m]; returns the held vertices."""
        return self.grab(point)

    def move(self, point: ArrayLike) -> None:
        """:meth:`settle` with the jaws at ``point`` [m], turned as they are."""
        self.settle(point, self.rotation)

    @property
    def engaged(self) -> bool:
        return self.holding

    @property
    def force_on_tissue(self) -> np.ndarray | None:
        """The jaws' pull on the tissue [N]: :attr:`force`'s opposite; None when nothing is held."""
        return -self.force if self.holding else None

    # -------------------------------------------------------------------------------------------- the iteration
    def _iterate(self, max_iterations: int, max_steps: int) -> bool:
        """Newton–Broyden iterations until every held vertex of every grasper on the solver is on its target
        (True) or ``max_iterations`` pass (False: the forces of the best iteration act). The graspers holding on one
        solver are solved together (:meth:`_group`): each patch's forces move the others'.

        The change of the forces is J's least-squares solution (the smallest forces where two patches ask for more
        than the method's surface can do between them). An iteration whose solve the solver refuses (a model far
        stiffer than the tissue overshoots: a surface turned inside out, a volume inverted), or that leaves the held
        vertices farther from their targets, is undone; J still learns from the second, and takes a quarter of the
        step after the first. A refusal in the last iteration allowed, or the :data:`RETRIES` + 1-th in a row, is
        raised."""
        group = self._group()
        self.iterations = self.steps = refused = 0
        error, misses = _errors(group)
        if misses <= 1.0:
            # on their targets, but perhaps not at equilibrium: a load, the support or a cut changed since the last
            # solve, or the forces were withdrawn (a grab again, a reset)
            self._solve(group, max_steps)
            error, misses = _errors(group)
        self.residual = largest_miss(error)
        while misses > 1.0:
            if self.iterations == max_iterations:
                return False
            self.iterations += 1
            jacobian = self._current_jacobian(group)
            change = np.linalg.lstsq(jacobian, error.ravel(), rcond=SINGULAR)[0]
            if self._learned is None:         # a model not yet sized by a solve: a short first step sizes it
                change = FIRST_STEP * change
            state, loads = self.solver.snapshot(), [dict(g._loads.by_node) for g in group]
            held = np.concatenate([g.held for g in group])
            before = self.solver.positions[held].ravel()
            try:
                self._apply(group, change, max_steps)
            except SolverError:
                _put_back(group, state, loads)
                refused += 1
                if self.iterations == max_iterations or refused > RETRIES:
                    raise
                self._jacobian = 4.0 * jacobian
                continue
            refused = 0
            self._learn(jacobian, change, self.solver.positions[held].ravel() - before)
            trial, trial_misses = _errors(group)
            if trial_misses > misses:
                _put_back(group, state, loads)
                continue
            error, misses, self.residual = trial, trial_misses, largest_miss(trial)
        return True

    def _group(self) -> list[Grasper]:
        """This grasper, then every other one holding on its solver, oldest first (each having taken hold of what a
        cut made within its reach)."""
        others = [g for g in _HOLDERS.get(self.solver, ()) if g is not self and g.holding]
        group = [self, *sorted(others, key=lambda g: g._serial)]
        for grasper in group:
            grasper._hold_what_a_cut_made()
        return group

    def _hold_what_a_cut_made(self) -> None:
        """Hold the vertices a cut added within the jaws' reach (the lips of a wound through the held patch), where
        they are: the jaws close on both sides of it. A cut appends vertices, so those beyond the count at the last
        look are the new ones."""
        count = self.solver.node_count
        if count == self._seen:
            return
        new = np.arange(self._seen, count)
        self._seen = count
        grip = (self.solver.positions[new] - self.position) @ self.rotation       # Rᵀ (x − p), row by row
        taken = np.concatenate([self.solver.fixed, _held_by_others(self)])
        near = (np.linalg.norm(grip, axis=1) <= self.radius) & ~np.isin(new, taken)
        if near.any():
            self.held = np.concatenate([self.held, new[near]])
            self._grip = np.concatenate([self._grip, grip[near]])

    def _apply(self, group: list[Grasper], change: np.ndarray, max_steps: int) -> None:
        """Each grasper's forces changed by its part of ``change`` ``(3K,)`` [N], and the solver's equilibrium
        under them."""
        _add_forces(group, change)
        self._solve(group, max_steps)

    def _solve(self, group: list[Grasper], max_steps: int) -> None:
        """The solver's equilibrium under the loads acting. A method that steps to it stops where a step moves
        less than :data:`SOLVE_FRACTION` of the tolerance per :data:`SOLVE_TIME` of simulated time: a speed, so the
        answer does not change with dt."""
        solver = self.solver
        tolerance = SOLVE_FRACTION * min(g.tolerance for g in group) * min(1.0, solver.dt / SOLVE_TIME)
        solver.solve_static(tolerance=tolerance, max_steps=max_steps, reset=False)
        self.steps += solver.last_solve.steps
        self._check_not_inverted()

    def _learn(self, jacobian: np.ndarray, change: np.ndarray, moved: np.ndarray) -> None:
        """J from the held vertices' motion ``moved`` ``(3K,)`` [m] under the forces' ``change`` ``(3K,)`` [N]."""
        if self._learned is None:
            jacobian = fitted_model(jacobian, change, moved)
        # Broyden's update, the smallest change of J that explains the motion (a new array: a refused move puts
        # the old one back)
        self._jacobian = jacobian + np.outer(moved - jacobian @ change, change) / float(change @ change)
        self._learned = self._jacobian

    def _error(self) -> np.ndarray:
        """``(k, 3)`` [m] each held vertex's target minus its position."""
        return self.targets() - self.solver.positions[self.held]

    def _current_jacobian(self, group: list[Grasper]) -> np.ndarray:
        """J (3K × 3K) [m/N] of the ``group``'s held vertices: the one learned while they held, or a new one (after a
        grab or a release in the group, or a cut that swapped the surface): the solver's own small-strain compliance
        where it has it (``point_compliance``, trusted as it is), else a model to be sized by the first solve (the
        solver's ``compliance_model``, or Boussinesq's)."""
        key = (self.solver.hybrid.surface, tuple((g._serial, g.held.size) for g in group))
        if self._jacobian is None or key != self._key:
            self._key = key
            held = np.concatenate([g.held for g in group])
            exact = solver_compliance(self.solver, "point_compliance", held)
            model = exact if exact is not None else solver_compliance(self.solver, "compliance_model", held)
            self._jacobian = np.array(model) if model is not None else self._half_space(held)
            self._learned = self._jacobian if exact is not None else None
        return self._jacobian

    def _half_space(self, held: np.ndarray) -> np.ndarray:
        """``(3K, 3K)`` [m/N] Boussinesq's normal compliance of the ``held`` vertices on each axis alike."""
        solver = self.solver
        normal = half_space_compliance(solver.rest_positions[held], solver.lumped_areas()[held],
                                       solver.youngs_modulus, solver.poisson_ratio)
        return np.kron(normal, np.eye(3))

    def _check_not_inverted(self) -> None:
        """Refuse a motion under which the solver's finite-strain volume turned an element inside out."""
        finite = getattr(self.solver, "finite", None)
        if finite is None:
            return
        ratios = finite.volume_ratios(self.solver.volume_displacement).min(axis=1)
        if ratios.min() <= 0.0:
            raise SolverError(
                f"the grasper's motion inverts {int(np.count_nonzero(ratios <= 0.0))} elements of the volume "
                f"(smallest J = det F {ratios.min():.3g}): no tissue follows it; nothing was changed; move or turn the "
                "jaws less far")

    # ------------------------------------------------------------------------------------------------ placing
    def _place(self, position, rotation) -> None:
        self._require_holding()
        self.position = checked_point(position, name="the jaws' position").copy()
        if rotation is not None:
            self.rotation = checked_rotation(rotation)

    def _require_holding(self) -> None:
        if not self.holding:
            raise SolverError("the grasper holds nothing; call grab(point) first")


def _held_by_others(grasper: Grasper) -> np.ndarray:
    """``(m,) int64`` the vertices of ``grasper``'s solver that other graspers hold."""
    others = [g.held for g in _HOLDERS.get(grasper.solver, ()) if g is not grasper and g.holding]
    return np.concatenate(others) if others else np.zeros(0, dtype=np.int64)


def _errors(group: list[Grasper]) -> tuple[np.ndarray, float]:
    """``(K, 3)`` [m] every held vertex's target minus its position, the ``group``'s in turn, and the largest miss
    of a grasper over its own tolerance."""
    errors = [g._error() for g in group]
    return np.concatenate(errors), max(largest_miss(e) / g.tolerance for e, g in zip(errors, group))


def _add_forces(group: list[Grasper], change: np.ndarray) -> None:
    """Each grasper's forces changed by its part of ``change`` ``(3K,)`` [N], the ``group``'s in turn."""
    parts = np.split(change.reshape(-1, 3), np.cumsum([g.held.size for g in group])[:-1])
    for grasper, part in zip(group, parts):
        grasper._loads.set(grasper.held, grasper._loads.at(grasper.held) + part)


def _put_back(group: list[Grasper], state: Snapshot, loads: list[dict]) -> None:
    """The solver's state and the ``group``'s loads as they were before an iteration."""
    state.restore(group[0].solver)
    for grasper, by_node in zip(group, loads):
        grasper._loads.by_node = by_node
