"""Finite-strain statics on a tet mesh: the converged equilibrium of a hyperelastic body (:mod:`.hyperelastic`),
with fixed nodes that may move (a base carried or turned by a grasper or a retractor), on linear tets
(:class:`NonlinearFEM`) or quadratic ones (:mod:`.nonlinear_quadratic`): both share :class:`HyperelasticStatics`.

Two ways to the same equilibrium ∂W/∂u = f (W the stored energy, f the nodal loads), both descending the total
potential Π(u) = W(u) − fᵀu with a backtracking line search, so every iteration lowers Π and the answer is a stable
equilibrium (a minimum of Π):

* :meth:`NonlinearFEM.solve`: Newton with the consistent tangent (where it is not positive definite, each element's
  projected to positive semi-definite: a descent direction still), load stepping when a full load does not
  converge; converged to a residual below :data:`RTOL` of the load. One factorisation per iteration.
* :meth:`NonlinearFEM.relax`: a fixed number of L-BFGS iterations preconditioned by the constant, prefactorised
  rest stiffness K₀ of :class:`~.linear.LinearFEM` (of :class:`~.quadratic.QuadraticFEM` on quadratic tets). The
  interactive path: warm-started from the last answer it costs back-substitutions only, and repeated under a
  constant load it converges to :meth:`solve`'s answer.

A dead load can have no stable equilibrium (a press above about the shear modulus over a small patch): then no
load step converges, or the converged state's exact tangent is not positive definite. :meth:`solve` raises
:class:`UnstableLoadError` with the fraction of the load it reached; callers say what the load means. Where Newton
does converge, on a state that crushes elements flat (:meth:`volume_ratios`), callers warn.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import SolverError
from ..mesh.tetmesh import TetMesh
from .assembly import scatter_elements, shape_gradients
from .hyperelastic import check_material, element_energy, element_tangents, internal_forces, material_parameters
from .factorise import factorise_spd, fill_reducing_order
from .linear import LinearFEM
from .material import DEFAULT_POISSON_RATIO, DEFAULT_YOUNGS_MODULUS, Material

if TYPE_CHECKING:
    import scipy.sparse as sp

#: A Newton solve has converged when the free residual is below this fraction of the load's size (the larger of the
#: applied forces and the support reactions, so a pure motion of the supports converges too).
RTOL = 1e-9
MAX_NEWTON = 25
#: Load stepping halves a failed increment down to this fraction of the load before giving up (so the largest
#: stable fraction it reports is known to about 3 %; a converging Newton needs far fewer than MAX_NEWTON).
MIN_LOAD_STEP = 1.0 / 32.0
#: Curvature pairs :meth:`NonlinearFEM.relax` keeps.
LBFGS_MEMORY = 8
_ARMIJO = 1e-4
_MAX_HALVINGS = 40


def in_fractions(attempt: Callable[[float], bool], *, first: float, smallest: float) -> float:
    """Continuation: ``attempt(fraction)`` solves under that fraction of a load (from the last success) and says
    whether it converged. Fractions grow by ``first``; the increment doubles after a success (up to what is left)
    and halves after a failure. Returns 1.0, or the last fraction reached once the increment falls below
    ``smallest``."""
    done, step = 0.0, first
    while done < 1.0:
        fraction = min(1.0, done + step)
        if attempt(fraction):
            done, step = fraction, min(2.0 * step, 1.0 - fraction) if fraction < 1.0 else step
            continue
        step *= 0.5
        if step < smallest:
            return done
    return done


class UnstableLoadError(SolverError):
    """A dead load beyond what the body can carry in a stable equilibrium; ``reached`` is the load fraction in
    [0, 1) at which the last stable equilibrium was found."""

    def __init__(self, message: str, *, reached: float):
        super().__init__(message)
        self.reached = float(reached)


class HyperelasticStatics:
    """Newton, line search, load stepping and the constant-factor relaxation, whatever the elements: a subclass
    calls :meth:`_setup` with its elements and their quadrature (:mod:`.hyperelastic`'s element loops)."""

    def _setup(self, material: str, elastic: Material, rest: np.ndarray, fixed_mask: np.ndarray,
               elements: np.ndarray, gradients: np.ndarray, weights: np.ndarray, rest_factor) -> None:
        """The state every element type shares: kernel parameters of ``material`` from the small-strain
        ``elastic``, rest positions ``(n, 3)`` [m], the ``(n, 3) bool`` fixed-dof mask, the elements ``(m, w)``
        with their rest shape-function gradients ``(m, q, w, 3)`` [1/m] and weights ``(m, q)`` [m³] at q points,
        and the factor of the rest stiffness K₀ on the free dofs."""
        self.params = material_parameters(material, shear_modulus=elastic.shear_modulus,
                                          lame_lambda=elastic.lame_lambda)
        self.rest = np.ascontiguousarray(rest, dtype=np.float64)
        self.free_dofs = np.flatnonzero(~fixed_mask.ravel())
        self.fixed_displacement = np.zeros_like(self.rest)
        self._fixed_mask = fixed_mask
        self._fixed_dofs = np.flatnonzero(self._fixed_mask.ravel())
        self.elements, self.gradients, self.weights = elements, gradients, weights
        self._rest_factor = rest_factor
        # Residual scale when neither loads nor reactions give one (a rigid motion of the supports): a force that
        # strains the body by 1e-3 over its size.
        size = float(np.linalg.norm(np.ptp(self.rest, axis=0)))
        self._force_floor = 1e-3 * elastic.youngs_modulus * size * size
        self._x = np.empty_like(self.rest)
        self._forces = np.empty_like(self.rest)
        width = 3 * elements.shape[1]
        self._tangents = np.empty((len(elements), width, width))
        self._order = None        # the tangents' fill-reducing order: one sparsity pattern, computed once
        self._memory: list[tuple[np.ndarray, np.ndarray, float]] = []    # relax's curvature pairs (s, y, 1/yᵀs)
        self._last: tuple[np.ndarray, np.ndarray] | None = None           # relax's last (u_f, ∂W/∂u_f)
        self.last_iterations = 0
        #: ``(3n, 3n)`` CSR stiffness [N/m] of springs to fixed anchors (ligaments: quadratic in u, ½ uᵀ K_s u),
        #: added to W, ∂W/∂u and the tangent; None without springs
        self._springs = None

    @property
    def node_count(self) -> int:
        return len(self.rest)

    @property
    def fixed_dofs(self) -> np.ndarray:
        """``(n, 3) bool`` the fixed dofs (read-only view)."""
        view = self._fixed_mask.view()
        view.flags.writeable = False
        return view

    # ------------------------------------------------------------------------------------------ energy and forces
    def energy(self, u: np.ndarray) -> float:
        """Stored energy W [J] at displacement ``u`` ``(n, 3)`` [m]."""
        np.add(self.rest, u, out=self._x)
        energy = float(element_energy(self._x, self.elements, self.gradients, self.weights, self.params))
        if self._springs is not None:
            flat = u.ravel()
            energy += 0.5 * float(flat @ (self._springs @ flat))
        return energy

    def internal_forces(self, u: np.ndarray) -> np.ndarray:
        """``(n, 3)`` ∂W/∂u [N] at displacement ``u`` [m] (at fixed dofs: minus the support reactions); the array
        is reused by the next call."""
        np.add(self.rest, u, out=self._x)
        internal_forces(self._x, self.elements, self.gradients, self.weights, self.params, self._forces)
        if self._springs is not None:
            self._forces += (self._springs @ u.ravel()).reshape(-1, 3)
        return self._forces

    def tangent(self, u: np.ndarray, *, project: bool = True) -> sp.csr_matrix:
        """``(3n, 3n)`` CSR tangent stiffness ∂²W/∂u² [N/m] at ``u``; element tangents projected to positive
        semi-definite when ``project``."""
        np.add(self.rest, u, out=self._x)
        element_tangents(self._x, self.elements, self.gradients, self.weights, self.params, bool(project),
                         self._tangents)
        tangent = scatter_elements(self.node_count, self.elements, self._tangents)
        return tangent if self._springs is None else (tangent + self._springs).tocsr()

    # --------------------------------------------------------------------------------------------- supports
    def set_fixed_displacement(self, displacement: ArrayLike) -> None:
        """Move the supports: ``displacement`` ``(n, 3)`` [m], read at the fixed dofs only."""
        displacement = np.asarray(displacement, dtype=np.float64)
        if displacement.shape != (self.node_count, 3) or not np.all(np.isfinite(displacement)):
            raise SolverError(f"fixed displacement must be a finite ({self.node_count}, 3) array [m], got shape "
                              f"{displacement.shape}")
        self.fixed_displacement[:] = np.where(self._fixed_mask, displacement, 0.0)
        self._forget()      # the supports' motion changes ∂W/∂u_f at fixed u_f: old curvature pairs are wrong

    # -------------------------------------------------------------------------------------------------- solves
    def solve(self, forces: ArrayLike, *, initial: np.ndarray | None = None, rtol: float = RTOL,
              max_iterations: int = MAX_NEWTON) -> np.ndarray:
        """``(n, 3)`` displacement [m] at the stable equilibrium under nodal ``forces`` ``(n, 3)`` [N] with the
        supports at :attr:`fixed_displacement` (Newton, line search, load stepping), from ``initial`` ``(n, 3)``
        (default: rest). A step that does not converge is halved: the loads and the supports'
        motion from where ``initial`` has them are applied in fractions. Raises :class:`UnstableLoadError` when no
        stable equilibrium is found."""
        forces = self._check_forces(forces)
        fixed = self._fixed_mask
        if initial is None:  # from rest: the first Newton step is the small-strain answer, shortened as needed
            u = start = np.zeros_like(forces)
        else:
            u = np.array(initial, dtype=np.float64)
            start = np.where(fixed, u, 0.0)
        motion = np.where(fixed, self.fixed_displacement, 0.0) - start
        if initial is not None and not motion.any() and self._converged(forces, u, rtol):
            self.last_iterations = 0  # already there (an interactive step under an unchanged load)
            return u
        state = {"u": u, "iterations": 0}

        def attempt(fraction: float) -> bool:
            trial = state["u"].copy()
            trial[fixed] = (start + fraction * motion)[fixed]
            converged, trial, taken = self._newton(fraction * forces, trial, rtol, max_iterations)
            state["iterations"] += taken
            if converged:
                state["u"] = trial
            return converged

        done = in_fractions(attempt, first=1.0, smallest=MIN_LOAD_STEP)
        if done < 1.0:
            raise UnstableLoadError(self._unstable_message(forces, done), reached=done)
        u, iterations = state["u"], state["iterations"]
        if not self._stable(u):
            raise UnstableLoadError(self._unstable_message(forces, done, saddle=True), reached=0.0)
        self.last_iterations = iterations
        return u

    def relax(self, forces: ArrayLike, u: np.ndarray, *, iterations: int, rtol: float = RTOL) -> bool:
        """Up to ``iterations`` quasi-Newton iterations on ``u`` ``(n, 3)`` [m] in place under ``forces`` ``(n, 3)``
        [N]: the interactive path. L-BFGS (Nocedal & Wright 2006, Algorithm 7.4) whose initial inverse Hessian is
        the constant, prefactorised K₀⁻¹ (as Liu, Bouaziz & Kavan 2017 do for real-time hyperelasticity), with a
        line search on Π: one back-substitution per iteration, no refactorisation. The curvature pairs are kept
        across calls (they depend on W alone, not on the load), so a drag keeps what earlier steps learnt.
        Returns True when ``u`` is at equilibrium (residual below ``rtol`` of the load's size, :meth:`solve`'s
        criterion, or no step can lower Π any more): further calls then change nothing."""
        free = self.free_dofs
        u[self._fixed_mask] = self.fixed_displacement[self._fixed_mask]
        flat_f = forces.ravel()
        for _ in range(int(iterations)):
            g, residual, converged = self._residual(flat_f, u, rtol)
            if converged:
                return True
            self._learn(u.ravel()[free], g[free])
            if not self._line_search(u, self._quasi_newton(residual), residual, forces):
                self._forget()
                if not self._line_search(u, np.asarray(self._rest_factor.solve(residual)), residual, forces):
                    return True       # Π cannot fall any further within its round-off
        return False

    def relax_memory(self) -> tuple:
        """What :meth:`relax` has learnt so far (its curvature pairs and last iterate), for
        :meth:`set_relax_memory`: put back, the next iterations are those of a twin that never did the work
        between."""
        return list(self._memory), self._last

    def set_relax_memory(self, memory: tuple) -> None:
        """Put back what :meth:`relax_memory` returned."""
        pairs, self._last = memory
        self._memory = list(pairs)

    def _learn(self, u_free: np.ndarray, g_free: np.ndarray) -> None:
        """Add the curvature pair from relax's last iterate to this one (skipped where yᵀs ≤ 0: not convex
        along s), keeping the newest :data:`LBFGS_MEMORY`."""
        last, self._last = self._last, (u_free.copy(), g_free.copy())
        if last is None:
            return
        s, y = u_free - last[0], g_free - last[1]
        curvature = float(y @ s)
        if curvature > 1e-12 * float(np.linalg.norm(y) * np.linalg.norm(s)):
            self._memory.append((s, y, 1.0 / curvature))
            del self._memory[:-LBFGS_MEMORY]

    def _forget(self) -> None:
        self._memory.clear()
        self._last = None

    def _quasi_newton(self, residual: np.ndarray) -> np.ndarray:
        """L-BFGS two-loop recursion: ≈ H⁻¹ r with K₀⁻¹ as the initial inverse Hessian."""
        q = residual.copy()
        alphas = []
        for s, y, rho in reversed(self._memory):
            alpha = rho * float(s @ q)
            q -= alpha * y
            alphas.append(alpha)
        z = np.asarray(self._rest_factor.solve(q), dtype=np.float64)
        for (s, y, rho), alpha in zip(self._memory, reversed(alphas)):
            z += s * (alpha - rho * float(y @ z))
        return z

    def _converged(self, forces, u, rtol) -> bool:
        return self._residual(forces.ravel(), u, rtol)[2]

    def _residual(self, flat_forces, u, rtol):
        """``(∂W/∂u (3n,), free residual f − ∂W/∂u (f,), converged)`` at ``u``: converged when the residual is
        below ``rtol`` of the load's size, the larger of the applied forces and the support reactions, or a floor."""
        g = self.internal_forces(u).ravel()
        residual = flat_forces[self.free_dofs] - g[self.free_dofs]
        scale = max(float(np.linalg.norm(flat_forces)), float(np.linalg.norm(g[self._fixed_dofs])),
                    self._force_floor)
        return g, residual, bool(np.linalg.norm(residual) <= rtol * scale)

    # -------------------------------------------------------------------------------------------------- internals
    def _newton(self, forces, u, rtol, max_iterations):
        """(converged, u, iterations) of Newton from ``u`` (copied) under ``forces``."""
        u = u.copy()
        flat_f = forces.ravel()
        for iteration in range(1, max_iterations + 1):
            _, residual, converged = self._residual(flat_f, u, rtol)
            if converged:
                return True, u, iteration - 1
            factor = self._tangent_factor(u)
            if factor is None:
                return False, u, iteration
            direction = np.asarray(factor.solve(residual))
            if not self._line_search(u, direction, residual, forces):
                return False, u, iteration
        return False, u, max_iterations

    def _tangent_factor(self, u):
        """The factor of the exact tangent on the free dofs where it is positive definite (quadratic convergence),
        else of the tangent with each element's projected to positive semi-definite (still a descent direction);
        None when neither factorises."""
        for project in (False, True):
            try:
                return self._factorise(self.tangent(u, project=project))
            except SolverError:
                continue
        return None

    def _factorise(self, tangent):
        """The factor of ``tangent`` ``(3n, 3n)`` on the free dofs, in the order computed at the first call."""
        free = self.free_dofs
        reduced = tangent[free][:, free].tocsc()
        if self._order is None:
            self._order = fill_reducing_order(reduced, free // 3)
        return factorise_spd(reduced, free // 3, order=self._order)

    def _line_search(self, u, direction, residual, forces) -> bool:
        """Backtrack along ``direction`` (free dofs) until Π = W − fᵀu decreases enough (Armijo); moves ``u`` in
        place and returns True, or leaves it and returns False when no step helps."""
        free = self.free_dofs
        flat_u = u.reshape(-1)
        slope = -float(residual @ direction)  # dΠ/dα at α = 0: negative for a descent direction
        if not slope < 0.0:
            return False
        base = flat_u[free].copy()
        energy = self.energy(u)
        work = float(forces.ravel() @ flat_u)
        potential = energy - work
        # Near convergence Π changes by less than its round-off: accept a step within that noise.
        noise = 1e-12 * (abs(energy) + abs(work))
        alpha = 1.0
        for _ in range(_MAX_HALVINGS):
            flat_u[free] = base + alpha * direction
            trial = self.energy(u) - float(forces.ravel() @ flat_u)
            if np.isfinite(trial) and trial <= potential + _ARMIJO * alpha * slope + noise:
                return True
            alpha *= 0.5
        flat_u[free] = base
        return False

    def _stable(self, u) -> bool:
        """Whether the exact (unprojected) tangent at ``u`` is positive definite on the free dofs."""
        try:
            self._factorise(self.tangent(u, project=False))
        except SolverError:
            return False
        return True

    def _unstable_message(self, forces, reached: float, *, saddle: bool = False) -> str:
        total = float(np.linalg.norm(forces.sum(axis=0)))
        what = ("the equilibrium it reaches is unstable (its tangent stiffness is not positive definite)" if saddle
                else f"no stable equilibrium beyond {100 * reached:.3g} % of it")
        return (f"a dead load of {total:.3g} N on this {self.material_name} body has {what}: the body would buckle "
                "or collapse under it; lower it (a press that deep needs a contact driven by displacement, a rigid "
                "tip, not a fixed force)")

    def volume_ratios(self, u: np.ndarray) -> np.ndarray:
        """``(m, q) float64`` J = det F [-] at each element's points at displacement ``u`` ``(n, 3)`` [m]: 1 at
        rest, ≤ 0 where an element is turned inside out."""
        f = np.einsum("ewi,eqwk->eqik", (self.rest + u)[self.elements], self.gradients, optimize=True)
        return np.linalg.det(f)

    def _check_forces(self, forces) -> np.ndarray:
        forces = np.asarray(forces, dtype=np.float64)
        if forces.shape != (self.node_count, 3) or not np.all(np.isfinite(forces)):
            raise SolverError(f"forces must be a finite ({self.node_count}, 3) array [N], got shape {forces.shape}")
        return forces


class NonlinearFEM(HyperelasticStatics):
    """Hyperelastic statics of ``mesh`` on linear tets (see the module docstring).

    Args:
        mesh: the tet mesh (rest shape).
        youngs_modulus: E [Pa] (Hooke's law at small strain).
        poisson_ratio: ν [-].
        fixed: the supports, as :class:`~.linear.LinearFEM` takes them.
        material: ``"corotated"`` or ``"neo-hookean"`` (:mod:`.hyperelastic`).
        linear: an existing :class:`~.linear.LinearFEM` of the same mesh, material and supports whose factor
            :meth:`relax` reuses (default: one is built); its ``springs`` (ligaments to fixed anchors, linear in u)
            act here too.

    Attributes:
        linear: the small-strain model (K₀ and its factor).
        fixed_displacement: ``(n, 3) float64`` [m] the supports' displacement (zero until
            :meth:`set_fixed_displacement`); entries of free dofs are unused.
        elements: ``(m, 4) int64`` the tets; ``gradients`` ``(m, 1, 4, 3) float64`` their rest shape-function
            gradients [1/m]; ``weights`` ``(m, 1)`` their volumes [m³] (one point: F is constant in a linear tet).
    """

    def __init__(self, mesh: TetMesh, *, youngs_modulus: float = DEFAULT_YOUNGS_MODULUS,
                 poisson_ratio: float = DEFAULT_POISSON_RATIO, fixed: ArrayLike, material: str = "neo-hookean",
                 linear: LinearFEM | None = None):
        self.material_name = check_material(material)
        self.linear = linear if linear is not None else LinearFEM(
            mesh, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio, fixed=fixed)
        self.mesh = mesh
        volumes = np.ascontiguousarray(mesh.volumes, dtype=np.float64)[:, None]
        self._setup(material, self.linear.material, mesh.points, self.linear.fixed_dofs,
                    np.ascontiguousarray(mesh.tets, dtype=np.int64), shape_gradients(mesh)[:, None], volumes,
                    self.linear.factor)
        self._springs = self.linear.spring_stiffness      # the LinearFEM's springs (ligaments), if any
