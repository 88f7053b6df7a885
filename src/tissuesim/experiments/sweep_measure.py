"""One solver in one load case of the sweep: its options, the cases its material carries, the quasi-static
solve (positions, wall time, steps), the median time of a step under the load, and the elements it turned
inside out."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InversionError, SolverError
from . import protocol
from .sweep_config import ExperimentConfig

if TYPE_CHECKING:
    from ..solvers.base import Solver


def method_options(method: str, config: ExperimentConfig) -> dict:
    """``make_solver`` options of ``method``: its ``solver_options``, and the material where the method has it."""
    from ..solvers import solver_class

    options = dict(config.solver_options.get(method, {}))
    if config.material in solver_class(method).materials:
        options.setdefault("material", config.material)
    return options


def stable_cases(reference: Solver, cases: list, node: int, info: dict) -> list:
    """The ``cases`` the ``reference`` solver's material can carry as dead loads; the others go into ``info``'s
    ``beyond_stable_press`` (with the largest stable press [N], the same for every force)."""
    from ..solvers.finite_strain import check_dead_press

    kept, beyond = [], []
    for case in cases:
        try:
            check_dead_press(reference, node, case.vector, None)
        except SolverError as error:
            beyond.append({"load": case.load, "force_N": float(case.force_N), "reason": str(error).split(";")[0]})
            continue
        kept.append(case)
    if beyond:
        info["beyond_stable_press"] = beyond
    return kept


def measure(solver: Solver, case: protocol.LoadCase, node: int, config: ExperimentConfig) -> dict:
    """Equilibrium positions and time, then the median step time with the load set, of one solver in one case."""
    force = case.vector
    solver.reset()
    solver.last_solve = None
    start = time.perf_counter()
    # Not settled within max_steps, or turned inside out (mass-spring): the last positions, and the report says so.
    positions = np.array(solver.solve_static(node, force, max_steps=config.max_steps, keep_unsettled=True),
                         dtype=np.float64)
    equilibrium_ms = 1e3 * (time.perf_counter() - start)
    report = solver.last_solve
    steps = int(report.steps) if report is not None else None
    converged = bool(report.converged) if report is not None else True
    if positions.shape != np.shape(solver.rest_positions) or not np.all(np.isfinite(positions)):
        raise SolverError(f"{type(solver).__name__} returned non-finite or misshapen positions for {case.label}")
    times = _step_times(solver, node, force, config)
    solver.clear_load()
    solver.reset()
    return {"positions": positions, "equilibrium_ms": equilibrium_ms, "equilibrium_steps": steps,
            "converged": converged, "step_ms": 1e3 * float(np.median(times))}


def _step_times(solver, node, force, config: ExperimentConfig) -> np.ndarray:
    """``(timing_steps,)`` wall times [s] of steps under the load, after the warm-up steps. A step that turns a
    mass-spring surface inside out (InversionError) still did its work and is timed; the solver then restarts from
    rest under the same load."""
    solver.reset()
    solver.set_load(node, force)
    times = []
    for taken in range(config.warmup_steps + config.timing_steps):
        start = time.perf_counter()
        try:
            solver.step(config.dt)
        except InversionError:
            solver.reset()
            solver.set_load(node, force)
        if taken >= config.warmup_steps:
            times.append(time.perf_counter() - start)
    return np.array(times)


def inverted_elements(solver: Solver) -> dict:
    """``{"inverted_elements": count}`` of a finite-strain solver's volume after its solve (none for linear)."""
    from ..solvers.finite_strain import inverted_element_count

    count = inverted_element_count(solver)
    return {} if count is None else {"inverted_elements": count}
