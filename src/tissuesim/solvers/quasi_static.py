"""The quasi-static solve of every method: :meth:`~QuasiStaticSolve.solve_static` checks its arguments, sets the load
and reaches equilibrium by the method's static solver or, where it has none, by stepping with damping until the
surface settles; a finite-strain load with no stable equilibrium restores the state it was given. A mixin of
:class:`~tissuesim.solvers.base.Solver`, which holds the state, the load calls, the method's ``_step`` and
``_static_solve``, the blow-up check and the workspace ``previous_positions``."""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import ArrayLike

from ..errors import InversionError, SolverError, TissuesimError
from ..fem.nonlinear import UnstableLoadError
from .checks import check_force, flag, positive_number, whole_count
from .finite_strain import check_dead_press, unstable_load_error, volume_range
from .report import SolveReport
from .state import farthest_node, motion_and_displacement, remaining_error

#: Relative accuracy of a stepped quasi-static solve: its remaining error over the largest displacement (methods
#: with a static solver of their own solve the equilibrium exactly).
DEFAULT_RTOL = 1e-5
DEFAULT_MAX_STEPS = 20000


class QuasiStaticSolve:
    """A solver's equilibrium under one load (see the module docstring)."""

    def solve_static(
        self,
        node: int | None = None,
        force: ArrayLike | None = None,
        *,
        radius: float | None = None,
        tolerance: float | None = None,
        rtol: float = DEFAULT_RTOL,
        max_steps: int = DEFAULT_MAX_STEPS,
        dt: float | None = None,
        reset: bool = True,
        keep_unsettled: bool = False,
    ) -> np.ndarray:
        """Quasi-static response: ``(n, 3) float64`` M_S positions [m] at equilibrium under ``force`` at ``node``;
        with neither given, at equilibrium under the loads acting now (any number: several tools at once), which
        stay as they are.

        ``radius`` spreads the force over a contact patch (:meth:`set_load`). Methods with a static solver of their
        own (the FEM-based ones, and the xpbd surface layer: :mod:`tissuesim.layer.static`) solve the equilibrium
        directly (a linear solve, exact to round-off). The others step (with the solver's
        damping) until settled: the remaining error, extrapolated from the decay of the per-step motion, is below
        ``rtol`` × the largest displacement, or the motion is below ``tolerance`` [m] if one is given. The load
        replaces every load acting (as :meth:`set_load`; their handles, a pin-head's too, no longer act) and stays
        applied afterwards. ``reset`` (default) starts from rest, so the answer depends only on the load (and on
        where :meth:`set_fixed_positions` put the fixed set, which it keeps).
        What was done, and whether linear elasticity is valid for the answer (``last_solve.warning``), is in
        :attr:`last_solve`. Raises SolverError when ``max_steps`` pass without settling (a mass-spring surface
        turned inside out: InversionError), or at once when the state blows up (see :meth:`step`); a refused solve
        changes nothing (the state, the loads and :attr:`last_solve` are as before). ``keep_unsettled`` returns the
        last state of a stepping method that did not settle, or turned inside out, instead (``last_solve.converged``
        is False), as the experiments record it.
        """
        tolerance = 0.0 if tolerance is None else positive_number("tolerance", tolerance, "m")
        rtol = positive_number("rtol", rtol, "1")
        if rtol >= 1.0:  # a remaining error as large as the answer itself accepts any state as settled
            raise SolverError(f"rtol is a relative accuracy and must lie in (0, 1), got {rtol!r}; e.g. 1e-5")
        max_steps = whole_count("max_steps", max_steps)
        dt = self._check_dt(dt)
        reset = flag("reset", reset)
        keep = flag("keep_unsettled", keep_unsettled)
        if node is None and force is None:
            return self._solve_under_loads(dt, tolerance, rtol, max_steps, reset, keep)
        if node is None or force is None:
            raise SolverError("solve_static takes a node and a force together, or neither (the loads acting now)")
        node = self._check_node(node)
        force = check_force(force)
        self.contact_patch(node, radius)  # a refused load must leave the state as it was: check before the reset
        check_dead_press(self, node, force, radius)
        before = self.snapshot()
        if reset:
            self._unloaded()
        self.set_load(node, force, radius=radius)
        return self._settle_or_restore(before, dt, tolerance, rtol, max_steps, keep)

    def _solve_under_loads(self, dt: float, tolerance: float, rtol: float, max_steps: int, reset: bool, keep: bool):
        """:meth:`solve_static` under the loads acting: they are kept through the reset and put back if refused."""
        loads = self.kept_loads()
        before = self.snapshot()
        if reset:
            self._unloaded()
            self.put_back_loads(loads)
        return self._settle_or_restore(before, dt, tolerance, rtol, max_steps, keep)

    def _settle_or_restore(self, before, dt: float, tolerance: float, rtol: float, max_steps: int,
                           keep: bool) -> np.ndarray:
        """:meth:`_settle`; where it is refused (a finite-strain solve that finds no stable equilibrium, a stepping
        method that does not settle, turns inside out or blows up), the solver's whole state ``before`` (a
        :class:`~.snapshot.Snapshot`: its loads, volume displacement and warm start too) is put back first, so a
        refused solve changes nothing."""
        try:
            return self._settle(dt, tolerance, rtol, max_steps, keep)
        except UnstableLoadError as error:
            refusal = unstable_load_error(self, error)
            before.restore(self)
            raise refusal from None
        except TissuesimError:
            before.restore(self)
            raise

    def _settle(self, dt: float, tolerance: float, rtol: float, max_steps: int, keep: bool) -> np.ndarray:
        """:meth:`solve_static`'s work once the load is set: the method's static solve, else stepping."""
        start = time.perf_counter()
        iterations = self._static_solve()
        if iterations is not None:
            self._check_blow_up(dt, " in its static solve", linear=self.material == "linear")
            self.last_solve = SolveReport(iterations, True, 0.0, tolerance, time.perf_counter() - start,
                                          **self._measures())
            return self.state.positions.copy()
        previous = self.previous_positions
        previous[:] = self.state.positions
        steps, motion, settled = 0, np.inf, False
        history = []
        while steps < int(max_steps) and not settled:
            try:
                self._step(dt)
            except InversionError:
                # The surface cannot come back: report the solve as unsettled at its last (finite) state.
                self.last_solve = SolveReport(steps, False, float(motion), tolerance, time.perf_counter() - start,
                                              **self._measures())
                if keep:
                    return self.state.positions.copy()
                raise
            steps += 1
            self._check_blow_up(dt, f" after {steps} step" + "s" * (steps > 1))
            motion, largest = motion_and_displacement(previous, self.state.positions, self.rest_positions)
            history.append(motion)
            settled = motion <= tolerance or remaining_error(history) <= rtol * largest or self.static
        self.last_solve = SolveReport(steps, settled, float(motion), tolerance, time.perf_counter() - start,
                                      **self._measures())
        if not (settled or keep):
            raise SolverError(
                f"{self.name} solver did not settle within {max_steps} steps of {dt:g} s (last step still moved "
                f"{motion:.3g} m); raise max_steps or damping, or loosen rtol"
            )
        return self.state.positions.copy()

    def _measures(self) -> dict:
        """A :class:`SolveReport`'s measures of the state: the largest node displacement from rest [m], the model's
        size [m], the material and its volume's range (:func:`~.finite_strain.volume_range`)."""
        return dict(largest_displacement=float(farthest_node(self.state.positions, self.rest_positions)[1]),
                    model_size=self.size, **volume_range(self))
