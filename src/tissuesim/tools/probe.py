"""A rigid probe (a sphere, or a capsule: a probe tip or an instrument shaft) that pushes the surface by
frictionless unilateral contact.

    probe = Probe(solver, radius=0.005)                 # a sphere of 5 mm
    positions = probe.press_static([0, 0, 0.0395])      # static equilibrium with the probe held there
    probe.force                                         # (3,) N on the probe, equal and opposite to the tissue's
    probe.move_to(center, end=tip)                      # a capsule from center to tip: one contact update
    solver.step()

The contact acts on the surface's vertices: vertex i at x_i has the gap g_i = |x_i − p_i| − R to the probe (p_i
the nearest point of its core: the centre, or the segment of a capsule) and is pushed along n_i = (x_i − p_i)/|·|
by a force λ_i n_i, λ_i ≥ 0 (push only, no friction), each vertex's force a load of its own on the solver
(:meth:`~tissuesim.solvers.base.Solver.add_load`), beside any other tool's. The forces solve the complementarity
conditions λ ≥ 0, g ≥ 0, λ·g = 0, to :attr:`Probe.tolerance` [m] in the residual max |min(λ_i w_ii, g_i)|.

Algorithm (a semi-smooth Newton iteration with an approximate Jacobian): each iteration takes the gaps of the
vertices near the probe (the active set is found again each time), predicts their motion under a change of the
forces by the normal compliance W of an elastic half-space of the solver's E and ν (Boussinesq,
:func:`~tissuesim.tools.probe_complementarity.half_space_compliance`, times a scalar learned by secant from the
solver's own answers), solves that linear complementarity problem exactly
(:func:`~tissuesim.tools.probe_complementarity.complementary_forces`) and applies the forces; one solve of the
solver then gives the true gaps. The converged answer is the solver's own equilibrium under contact: the model only sets how fast it is reached, so it does not change with dt, the
iteration caps or the masses. :meth:`Probe.press_static` iterates to the tolerance (methods whose step is a static
solve take one step per iteration; the others step until settled). The interactive path is one contact update per
:meth:`Probe.move_to` or :meth:`Probe.update`, each followed by the caller's ``solver.step()``.

Contact on vertices only lets the surface between vertices cut into the probe: a triangle of circumradius ρ lets a
sphere of radius R sink R − √(R² − ρ²) ≈ ρ²/2R before any vertex touches it. A probe no larger than the triangles
under it (ρ ≥ R) could pass between vertices, so :meth:`Probe.move_to` refuses it there; where the sink exceeds
:data:`SINK_WARNING` × R it warns once.

A frictionless probe pushes each vertex away from its core, so it presses the body only from outside: a probe whose
core lies inside the body (placed there, or pressed deeper than its radius from the surface) would push the surface
above its core outward, and a probe enclosing the body every vertex; both are refused where placed, and a press in
which the surface passes over the core is refused too. A refused call changes nothing: the solver's state and loads
and the probe's own are put back as they were.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import BoundaryConditionError, SolverError, first_indices, warn
from .probe_complementarity import (complementary_forces, core_samples, gaps_and_normals, half_space_compliance,
                            undetected_depth, vertex_spans, winding_numbers)
from ..solvers.checks import checked_point, positive_number, whole_count
from ..solvers.load_set import VertexLoads
from ..solvers.snapshot import refusal_restores
from .base import Tool

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..solvers.base import Solver

#: Default contact tolerance: the largest complementarity residual, as a fraction of the probe's radius.
TOLERANCE_FRACTION = 1e-3
#: Vertices whose gap is below this fraction of R are the candidates of each contact update.
MARGIN_FRACTION = 0.1
#: A warning when the surface between vertices can sink this fraction of R into the probe undetected.
SINK_WARNING = 0.05
#: The interactive update of a method whose step is not a static solve moves the forces this fraction of the way:
#: one step goes only part of the way to the equilibrium, so a full Newton step would overshoot.
RELAXATION = 0.3
DEFAULT_MAX_ITERATIONS = 60
#: :meth:`Probe.settle`'s default: the contact iterations one frame may spend.
FRAME_ITERATIONS = 8
DEFAULT_MAX_STEPS = 20000
#: Bounds of the secant scale of the half-space model (the solver's compliance over Boussinesq's).
SCALE_RANGE = (1e-3, 1e3)
#: The most the secant scale changes in one iteration (a factor either way).
SCALE_STEP = 2.0


class Probe(Tool):
    """A rigid sphere or capsule of radius R pressing a solver's surface (see the module docstring).

    Args:
        solver: any :class:`~tissuesim.solvers.base.Solver`.
        radius: R [m], positive.
        tolerance: largest complementarity residual [m] a static press accepts; default
            :data:`TOLERANCE_FRACTION` × R.

    Attributes:
        center: ``(3,) float64`` the sphere's centre or the capsule's first end [m], or None (not placed).
        end: ``(3,) float64`` the capsule's second end [m], or None (a sphere).
        scale: the solver's normal compliance over the half-space model's, learned by :meth:`press_static`.
        iterations, steps, residual: of the last :meth:`press_static`: Newton iterations, solver steps, and the
            final residual [m].
    """

    kind = "probe"
    needs = "loads on surface vertices and a static solve"

    def __init__(self, solver: Solver, *, radius: float, tolerance: float | None = None):
        for needed in ("positions", "rest_positions", "add_load", "move_load", "remove_load", "loads", "step"):
            if not hasattr(solver, needed):
                raise SolverError(f"Probe needs a solver (from tissuesim.make_solver), got {type(solver).__name__}")
        self.solver = solver
        self.radius = positive_number("probe radius", radius, "m")
        self.tolerance = (TOLERANCE_FRACTION * self.radius if tolerance is None
                          else positive_number("contact tolerance", tolerance, "m"))
        self.center: np.ndarray | None = None
        self.end: np.ndarray | None = None
        self.scale = 1.0
        self.iterations, self.steps, self.residual = 0, 0, np.inf
        self._loads = VertexLoads(solver)       # a load per vertex it pushes
        self._surface = None                    # the surface the cached arrays below belong to
        self._spans = self._areas = None
        self._warned = False

    # ------------------------------------------------------------------------------------------------ reading
    @property
    def force(self) -> np.ndarray:
        """``(3,) float64`` the contact force on the probe [N]: minus the sum of what it puts on the tissue."""
        return -self._loads.total()

    @property
    def contacts(self) -> np.ndarray:
        """``(k,) int64`` sorted surface vertices the probe pushes now."""
        self._loads.forget_withdrawn()
        return np.array(sorted(self._loads.by_node), dtype=np.int64)

    def gaps(self) -> np.ndarray:
        """``(n,) float64`` each surface vertex's gap to the probe at the current positions [m] (negative: inside)."""
        self._require_placed()
        return gaps_and_normals(self.solver.positions, self.center, self.end, self.radius)[0]

    # ----------------------------------------------------------------------------------------------- driving
    def move_to(self, center: ArrayLike, end: ArrayLike | None = None) -> np.ndarray:
        """Move the probe: a sphere at ``center`` ``(3,)`` [m], or with ``end`` ``(3,)`` [m] a capsule from
        ``center`` to ``end``; one contact update at the current positions (call ``solver.step()`` next). Returns
        :attr:`force`. Refused (SolverError, nothing changed) where the probe is no larger than the triangles
        under it, would reach the fixed region, encloses the body or has its core inside it."""
        with refusal_restores(self, solving=False):
            self._place(center, end)
            self._relaxed_update()
        return self.force

    def update(self) -> None:
        """One contact update at the probe's place and the current positions: the vertices near it found again,
        their forces from one Newton step (see the module docstring). A held probe calls it each frame."""
        self._require_placed()
        with refusal_restores(self, solving=False):
            self._relaxed_update()

    def press_static(self, center: ArrayLike, end: ArrayLike | None = None, *,
                     max_iterations: int = DEFAULT_MAX_ITERATIONS, max_steps: int = DEFAULT_MAX_STEPS) -> np.ndarray:
        """``(n, 3) float64`` the surface at static equilibrium with the probe held at ``center`` (a capsule to
        ``end``) [m], every other load acting too; the probe's loads stay applied (read :attr:`force`).

        Iterates contact updates and solves until the complementarity residual is within :attr:`tolerance`;
        between two updates a method whose step is not a static solve steps until the remaining motion is below a
        tenth of it (at most ``max_steps`` steps). Raises SolverError when ``max_iterations`` pass first, or where
        :meth:`move_to` refuses the place, or the solver's own error when it cannot carry an iteration's forces; a
        refused press changes nothing (the solver's state and loads, and the probe, are as before the call)."""
        max_iterations = whole_count("max_iterations", max_iterations)
        max_steps = whole_count("max_steps", max_steps)
        with refusal_restores(self, solving=True):
            self._place(center, end)
            if not self._iterate(max_iterations, max_steps):
                raise SolverError(
                    f"the probe's contact did not converge in {max_iterations} iterations (residual "
                    f"{self.residual:.3g} m, tolerance {self.tolerance:.3g} m); nothing was changed; raise "
                    "max_iterations or the tolerance")
        return self.solver.positions.copy()

    def settle(self, center: ArrayLike, end: ArrayLike | None = None, *,
               max_iterations: int = FRAME_ITERATIONS) -> bool:
        """A frame's worth of :meth:`press_static`: the probe at ``center`` (a capsule to ``end``) [m] and at most
        ``max_iterations`` contact iterations, each a solve of the solver, leaving the solver at its equilibrium
        under the last iteration's forces; returns whether the contact converged (if not, the next call goes on
        from there). What a viewer or a script calls each frame where the probe moved: one relaxed :meth:`update`
        before a dynamic step lags and rings instead, the step not being the tissue's equilibrium. Raises what
        :meth:`press_static` raises for a place it refuses or forces the solver cannot carry, and then changes
        nothing."""
        max_iterations = whole_count("max_iterations", max_iterations)
        with refusal_restores(self, solving=True):
            self._place(center, end)
            return self._iterate(max_iterations, DEFAULT_MAX_STEPS)

    def release(self) -> None:
        """Withdraw the probe: its loads leave the solver (the others act on); it is no longer placed."""
        self._loads.set(np.zeros(0, dtype=np.int64), np.zeros((0, 3)))
        self.center = self.end = None

    # the Tool protocol: a press or a move is a frame's worth of contact where the probe is put
    def press(self, point: ArrayLike) -> bool:
        """:meth:`settle` with the probe's centre at ``point`` [m]; returns whether the contact converged."""
        return self.settle(point)

    def move(self, point: ArrayLike) -> bool:
        """:meth:`settle` with the probe's centre at ``point`` [m], a capsule's shaft carried along with it; returns
        whether the contact converged. Refused (SolverError) for a probe not placed: :meth:`press` it first."""
        if self.center is None:
            raise SolverError("the probe is not placed; press(point) it first")
        center = checked_point(point)
        end = None if self.end is None else center + (self.end - self.center)
        return self.settle(center, end)

    @property
    def engaged(self) -> bool:
        return self.center is not None

    @property
    def force_on_tissue(self) -> np.ndarray | None:
        """The probe's push on the tissue [N]: :attr:`force`'s opposite; None when it is not placed."""
        return None if self.center is None else -self.force

    # ------------------------------------------------------------------------------------------ contact update
    def _iterate(self, max_iterations: int, max_steps: int) -> bool:
        """Contact updates and solves at the probe's place until the residual is within the tolerance (True) or
        ``max_iterations`` pass (False: the loads of the last iteration act)."""
        self.steps = 0
        for iteration in range(1, max_iterations + 1):
            nodes, gaps, predicted = self._newton_step()
            self.steps += self._solve(max_steps)
            self._check_core_outside()
            self._learn_scale(nodes, gaps, predicted)
            self.iterations, self.residual = iteration, self._residual()
            if self.residual <= self.tolerance:
                return True
        return False

    def _relaxed_update(self) -> None:
        """The interactive update: a full Newton step for a method whose step is a static solve, else
        :data:`RELAXATION` of one."""
        self._newton_step(1.0 if getattr(self.solver, "static", False) else RELAXATION)

    def _newton_step(self, relaxation: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One contact update, moving the forces ``relaxation`` of the way to the Newton step's; returns
        ``(candidates (k,), their gaps before (k,) [m], predicted gaps (k,) [m])``."""
        solver = self.solver
        gaps, normals = gaps_and_normals(solver.positions, self.center, self.end, self.radius)
        nodes = np.flatnonzero(gaps < MARGIN_FRACTION * self.radius)
        nodes = nodes[~np.isin(nodes, solver.fixed)]
        held = np.linalg.norm(self._loads.at(nodes), axis=1)
        compliance = self._compliance(nodes, normals[nodes])
        forces = held + relaxation * (complementary_forces(compliance, gaps[nodes], held) - held)
        pushed = forces > 0.0
        self._loads.set(nodes[pushed], forces[pushed, None] * normals[nodes[pushed]])
        return nodes, gaps[nodes], gaps[nodes] + compliance @ (forces - held)

    def _compliance(self, nodes: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """``(k, k)`` [m/N] the normal compliance of ``nodes`` along their ``normals`` ``(k, 3)``: the solver's own
        where it has it exactly (``contact_compliance``: the Newton step is then exact for a linear method), else the
        scaled half-space model."""
        solver = self.solver
        exact = getattr(solver, "contact_compliance", None)
        found = None if exact is None else exact(nodes, normals)
        if found is not None:
            return found
        return self.scale * half_space_compliance(solver.rest_positions[nodes], self._surface_arrays()[1][nodes],
                                                  solver.youngs_modulus, solver.poisson_ratio)

    def _residual(self) -> float:
        """max |min(λ_i w_ii, g_i)| [m] over the vertices near the probe: a gap where no force acts, the force's
        own dimple where a vertex is pushed but left the probe."""
        gaps, normals = gaps_and_normals(self.solver.positions, self.center, self.end, self.radius)
        residual = np.minimum(gaps, 0.0)
        nodes = self.contacts
        own = np.diagonal(self._compliance(nodes, normals[nodes])) if nodes.size else np.zeros(0)
        pushes = np.linalg.norm(self._loads.at(nodes), axis=1)
        residual[nodes] = np.minimum(own * pushes, gaps[nodes])
        return float(np.abs(residual).max())

    def _learn_scale(self, nodes: np.ndarray, before: np.ndarray, predicted: np.ndarray) -> None:
        """Secant update of :attr:`scale` from the gaps' true change over the model's prediction: only from a
        predicted change well above the tolerance (near convergence the ratio of two small changes is noise, and
        learning from it threw the scale between 1e-3 and 1e2 on a coarse sphere), and by at most a factor
        :data:`SCALE_STEP` an iteration."""
        if nodes.size == 0:
            return
        model = predicted - before
        true = self.gaps()[nodes] - before
        norm = float(model @ model)
        if np.sqrt(norm) > 10.0 * self.tolerance:
            ratio = float(np.clip(float(true @ model) / norm, 1.0 / SCALE_STEP, SCALE_STEP))
            self.scale = float(np.clip(self.scale * ratio, *SCALE_RANGE))

    def _solve(self, max_steps: int) -> int:
        """The solver's equilibrium under the loads acting (:meth:`Solver.solve_static` with no load of its own: a
        direct solve where the method has one, else steps until the motion is below a tenth of the tolerance);
        returns the steps taken."""
        self.solver.solve_static(tolerance=0.1 * self.tolerance, max_steps=max_steps, reset=False)
        return self.solver.last_solve.steps

    # ------------------------------------------------------------------------------------------------ placing
    def _place(self, center, end) -> None:
        """Check and take the probe's place (nothing changes when refused)."""
        center = checked_point(center, name="the probe centre").copy()
        end = None if end is None else checked_point(end, name="the capsule end").copy()
        gaps = gaps_and_normals(self.solver.positions, center, end, self.radius)[0]
        self._check_outside(center, end, gaps)
        near = np.flatnonzero(gaps < MARGIN_FRACTION * self.radius)
        held = np.intersect1d(near[gaps[near] < 0.0], self.solver.fixed)
        if held.size:
            raise BoundaryConditionError(
                f"the probe reaches the fixed region: {held.size} fixed vertices lie inside it (first: "
                f"{first_indices(held)}), which no force can move; keep the probe away from the support")
        touching = np.flatnonzero(gaps < 2 * SINK_WARNING * self.radius)
        self._check_resolution(touching if touching.size else np.array([int(np.argmin(gaps))]))
        self.center, self.end = center, end

    def _check_resolution(self, nodes: np.ndarray) -> None:
        """Refuse a probe no larger than the triangles under it; warn once where they can sink into it."""
        span = float(self._surface_arrays()[0][nodes].max())
        if span >= self.radius:
            raise SolverError(
                f"the probe (radius {self.radius:.3g} m) is no larger than the surface's triangles under it "
                f"(circumradius up to {span:.3g} m): it could pass between their vertices; use a radius above "
                f"{span:.3g} m or a finer surface")
        sink = undetected_depth(span, self.radius)
        if sink > SINK_WARNING * self.radius and not self._warned:
            self._warned = True
            warn(f"the surface's triangles under the probe (circumradius up to {span:.3g} m) can sink "
                 f"{sink:.3g} m ({100 * sink / self.radius:.0f} % of its radius) into it between vertices; use a "
                 f"radius of at least {span / np.sqrt(1 - (1 - SINK_WARNING) ** 2):.3g} m or a finer surface")

    def _check_outside(self, center: np.ndarray, end: np.ndarray | None, gaps: np.ndarray) -> None:
        """Refuse a probe that encloses the body or whose core lies inside it (``gaps`` ``(n,)`` [m] of every
        vertex to it): a frictionless probe pushes each vertex away from its core, so there it would push the
        surface outward, or feel nothing at all from inside; only a probe outside the surface presses it."""
        if np.all(gaps < 0.0):
            raise SolverError(
                f"the probe (radius {self.radius:.3g} m) encloses the whole body: all {gaps.size} surface vertices "
                "lie inside it, and it would push each of them outward, away from its core; put the probe outside "
                "the surface, touching it")
        point = self._core_inside(center, end)
        if point is not None:
            raise SolverError(
                f"the probe's {_core_name(end)} lies inside the body, at {np.round(point, 6).tolist()} m, "
                f"{self._distance_to_surface(point):.3g} m from the nearest surface vertex: a frictionless probe "
                "pushes each vertex away from its core, so it would push the surface outward (a probe cannot pull), "
                f"or feel nothing; put it outside the surface, less than its radius {self.radius:.3g} m into it")

    def _check_core_outside(self) -> None:
        """Refuse a press in which the surface passed over the probe's core: the vertices that crossed it are
        pushed away from it, the wrong way, and the contact can converge there, mirrored (a press deeper than the
        vertex contact can follow)."""
        point = self._core_inside(self.center, self.end)
        if point is not None:
            raise SolverError(
                f"the surface passed over the probe's {_core_name(self.end)} while pressing (at "
                f"{np.round(point, 6).tolist()} m, {self._distance_to_surface(point):.3g} m from the nearest surface "
                "vertex, it lies inside the body): "
                "its vertices would be pushed outward, the wrong way, so the press is refused and nothing was "
                f"changed; press less deep (the probe's radius is {self.radius:.3g} m) or with a larger probe")

    def _core_inside(self, center: np.ndarray, end: np.ndarray | None) -> np.ndarray | None:
        """``(3,)`` the first point of the probe's core [m] inside the body at the current positions, or None."""
        core = core_samples(center, end, self.radius)
        inside = winding_numbers(core, self.solver.positions, self.solver.hybrid.surface.triangles) > 0.5
        return core[np.argmax(inside)] if inside.any() else None

    def _distance_to_surface(self, point: np.ndarray) -> float:
        """The distance [m] from ``point`` ``(3,)`` to the nearest surface vertex now."""
        return float(np.linalg.norm(self.solver.positions - point, axis=1).min())

    def _surface_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(spans (n,) [m], areas (n,) [m²])``: the largest triangle circumradius at each vertex of the solver's
        surface now, and its lumped area. Every use reads them here, so after a cut (which swaps the surface and
        adds vertices) each entry point sees the cut surface, never the one the probe was placed on."""
        surface = self.solver.hybrid.surface
        if surface is not self._surface:
            self._surface = surface
            self._spans = vertex_spans(surface.vertices, surface.triangles)
            self._areas = self.solver.lumped_areas()
        return self._spans, self._areas

    def _require_placed(self) -> None:
        if self.center is None:
            raise SolverError("the probe is not placed; call move_to(center) or press_static(center) first")


def _core_name(end) -> str:
    return "centre" if end is None else "core (the segment from its centre to its end)"


