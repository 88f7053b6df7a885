"""What a worker does for one task: the fem reference of a load, or one case measured against it.

Each worker process keeps a small cache (:data:`CACHE`): the hybrid mesh of a model (keyed by its content hash)
and each solver built on it (keyed by model, method, options and material), so the mesh and the solver's
factorisation are built once per worker, not once per case. A solver is reset before every case, so the cache
never changes an answer. Threads of one worker share the cache under a lock.
"""

from __future__ import annotations

import json
import threading
import time
from typing import TYPE_CHECKING

import numpy as np

from ..experiments import protocol
from .cases import Case, ModelRef

if TYPE_CHECKING:
    from ..mesh.hybrid import HybridMesh
    from ..solvers.base import Solver

#: Distinct solvers a worker keeps at most (the oldest goes first); meshes are kept while a solver uses them.
MAX_SOLVERS = 8

_LOCK = threading.RLock()
CACHE: dict = {"meshes": {}, "solvers": {}, "builds": 0}


def hybrid_of(model: ModelRef) -> HybridMesh:
    """The :class:`~tissuesim.mesh.hybrid.HybridMesh` (with fine volume) of ``model``, built once per worker."""
    with _LOCK:
        if model.key not in CACHE["meshes"]:
            CACHE["meshes"][model.key] = _build(model)
            CACHE["builds"] += 1
        return CACHE["meshes"][model.key]


def _build(model: ModelRef):
    from ..experiments.inputs import builtin_surface, check_fine_volume
    from ..mesh.hybrid import HybridMesh

    if model.kind == "bundle":
        hybrid = HybridMesh.load(model.source)
        check_fine_volume(hybrid, model.source)
        return hybrid
    if model.kind == "builtin":
        surface = builtin_surface(model.source, resolution=model.resolution, scale=model.scale)
    else:
        from ..io import read_surface

        surface = read_surface(model.source, scale=model.scale, repair=model.repair)
    return HybridMesh.build(surface, fine_volume=True, progress=False)


def solver_of(model: ModelRef, method: str, options: str, material: tuple) -> Solver:
    """The solver of ``method`` with ``options`` (JSON) and ``material`` on ``model``, reset, built once per
    worker."""
    from ..solvers.registry import make_solver

    key = (model.key, method, options, material[1:])
    with _LOCK:
        solvers = CACHE["solvers"]
        if key not in solvers:
            if len(solvers) >= MAX_SOLVERS:
                solvers.pop(next(iter(solvers)))
            _, youngs_modulus, poisson_ratio, density = material
            solvers[key] = make_solver(method, hybrid_of(model), youngs_modulus=youngs_modulus,
                                       poisson_ratio=poisson_ratio, density=density, **json.loads(options))
        solver = solvers.pop(key)
        solvers[key] = solver            # most recently used last
    solver.clear_load()
    solver.reset()
    return solver


def load_of(case: Case, hybrid: HybridMesh) -> tuple[int, np.ndarray]:
    """The loaded M_S node and the force ``(3,) float64`` [N] of ``case`` on ``hybrid`` (a probe's or a grasper's:
    its unit direction): the protocol's load node (§8.3), or the node nearest a grasper's given point, or for a
    random load a node drawn among those whose contact patch clears the fixed region, a direction uniform on the
    sphere and a magnitude uniform in the range, from the case's own seed (the same draw wherever it runs)."""
    vertices = hybrid.surface.vertices
    if case.random is None:
        node = (protocol.load_node(vertices, hybrid.surface.triangles) if case.point is None else
                int(np.argmin(np.linalg.norm(vertices - np.asarray(case.point), axis=1))))
        size = 1.0 if case.force_N is None else float(case.force_N)
        return node, size * np.asarray(case.direction, dtype=np.float64)
    seed, index, lowest, highest = case.random
    rng = np.random.default_rng([seed, index])
    node = int(rng.choice(_clear_nodes(vertices, case.radius)))
    direction = rng.normal(size=3)
    return node, rng.uniform(lowest, highest) * direction / np.linalg.norm(direction)


def _clear_nodes(vertices: np.ndarray, radius: float | None) -> np.ndarray:
    """``(k,) int64`` the M_S nodes farther than ``radius`` [m] (or than nothing) from every fixed node."""
    from scipy.spatial import cKDTree

    fixed = protocol.fixed_nodes(vertices)
    distance, _ = cKDTree(vertices[fixed]).query(vertices)
    return np.flatnonzero(distance > (radius or 0.0))


def equilibrium(solver: Solver, case: Case, node: int, load: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(n, 3) float64`` M_S positions [m] at equilibrium under ``case``'s tool, and the ``(3,)`` force [N] on the
    tissue; the loads stay applied. A pin-head's ``load`` is its force; a probe's and a grasper's, their unit
    direction d (:data:`EQUILIBRIA`)."""
    return EQUILIBRIA[case.tool](solver, case, node, load)


def _pressed(solver, case: Case, node: int, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A probe's: the sphere, touching the node's rest position from outside (centre x − R d), is held ``depth``
    further along d; the force on the tissue is the probe's reaction reversed."""
    from ..tools.probe import Probe

    solver.reset()
    probe = Probe(solver, radius=case.radius)
    centre = np.asarray(solver.rest_positions)[node] + (case.depth - case.radius) * direction
    positions = np.array(probe.press_static(centre, max_steps=case.record.max_steps))
    return positions, -np.asarray(probe.force, dtype=np.float64)


def _grasped(solver, case: Case, node: int, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A grasper's: the jaws close at rest on the surface within ``radius`` of the case's point (else the node's
    rest position) and are carried ``depth`` along d, at static equilibrium; the force on the tissue is the jaws'
    reaction reversed. A refused grab or move is raised (the case fails with its message)."""
    from ..tools.grasper import Grasper

    solver.reset()
    grasper = Grasper(solver, radius=case.radius)
    point = np.asarray(solver.rest_positions)[node] if case.point is None else np.asarray(case.point)
    grasper.grab(point)
    try:
        grasper.move_to(point + case.depth * direction, max_steps=case.record.max_steps)
    except Exception:
        grasper.release()   # a solver kept for the next case holds nothing of this one
        raise
    return np.array(solver.positions), -grasper.force


def _pulled(solver, case: Case, node: int, force: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return _settled(solver, node, force, case), np.asarray(force, dtype=np.float64)


#: How each tool reaches its equilibrium: ``(solver, case, node, load) -> (positions (n, 3) [m], force (3,) [N])``.
EQUILIBRIA = {"pin-head": _pulled, "probe": _pressed, "grasper": _grasped}


def _settled(solver, node: int, force: np.ndarray, case: Case) -> np.ndarray:
    """A pin-head's equilibrium; a solve that has not settled within ``max_steps`` keeps its last (finite)
    positions, as the experiments record it (``converged`` false in the row), anything else is raised."""
    solver.last_solve = None
    return np.array(solver.solve_static(node, force, radius=case.radius, max_steps=case.record.max_steps,
                                        keep_unsettled=True))


def reference(case: Case) -> dict:
    """The reference of ``case`` (a task of its own), as arrays: ``positions`` ``(n, 3) float64`` [m] of the fem
    method under the case's load; or for a contact reference its ``response`` ``(n, 3, 3)`` [m/N] per unit force,
    ``samples`` ``(k,) int64`` and ``converged`` (:class:`tissuesim.experiments.reference.ContactReference`)."""
    if case.reference[0] == "contact":
        from ..experiments.reference import RefinementSettings, contact_reference

        _, youngs_modulus, poisson_ratio, _ = case.material
        hybrid = hybrid_of(case.model)
        node, _ = load_of(case, hybrid)
        settings = RefinementSettings(max_levels=case.reference[1], samples=case.record.samples)
        found = contact_reference(hybrid, node, case.radius, youngs_modulus=youngs_modulus,
                                  poisson_ratio=poisson_ratio, settings=settings, shipped=case.reference[2])
        return {"response": found.response, "samples": np.asarray(found.samples, dtype=np.int64),
                "converged": np.array(found.converged)}
    solver = solver_of(case.model, protocol.REFERENCE, "{}", case.material)
    node, load = load_of(case, solver.hybrid)
    return {"positions": equilibrium(solver, case, node, load)[0]}


def _metrics(case: Case, solver, node: int, force, positions, reference: dict) -> dict:
    """The errors of ``positions`` against ``reference`` [m], and relative to the reference's RMS displacement."""
    rest = np.asarray(solver.rest_positions)
    if "positions" in reference:
        nodes = protocol.sample_nodes(rest, node, min(case.record.samples, len(rest)))
        return {"rmse_m": protocol.rmse(positions, reference["positions"], nodes),
                "relative_rmse": protocol.relative_rmse(positions, reference["positions"], rest, nodes)}
    from ..experiments.contact_protocol import METRICS, contact_metrics

    target = rest + reference["response"] @ np.asarray(force, dtype=np.float64)
    found = contact_metrics(positions, target, rest, reference["samples"], *solver.contact_patch(node, case.radius))
    row = {"reference_converged": bool(reference["converged"])}
    for name in METRICS:
        row[f"{name}_m"] = None if found[f"{name}_mm"] is None else found[f"{name}_mm"] / 1e3
        row[f"relative_{name}"] = found[f"relative_{name}"]
    return row


def run_case(case: Case, reference_arrays: dict | None) -> dict:
    """One case measured: ``{"row": metrics, "field": (n, 3) float32 displacement [m] or None}``; an error of the
    case's own (a refused option, a solve that does not settle) is returned as the row's ``error``, not raised."""
    start = time.perf_counter()
    try:
        return _measured(case, reference_arrays, start)
    except Exception as error:  # noqa: BLE001 - a case's failure is its result; the study goes on
        return {"row": {"status": "failed", "error": f"{type(error).__name__}: {error}",
                        "case_ms": 1e3 * (time.perf_counter() - start)}, "field": None}


def _measured(case: Case, reference_arrays, start: float) -> dict:
    record = case.record
    solver = solver_of(case.model, case.method, case.options, case.material)
    node, load = load_of(case, solver.hybrid)
    solved = time.perf_counter()
    positions, force = equilibrium(solver, case, node, load)
    rest = np.asarray(solver.rest_positions)
    row = {"status": "done", "error": "", "tool": case.tool, "depth_m": case.depth, "node": node,
           "force_x": force[0], "force_y": force[1], "force_z": force[2], "surface_nodes": len(rest),
           "solve_ms": 1e3 * (time.perf_counter() - solved),
           "max_displacement_m": float(np.linalg.norm(positions - rest, axis=1).max()),
           "converged": True if solver.last_solve is None else bool(solver.last_solve.converged)}
    if record.metrics:
        row.update(_metrics(case, solver, node, force, positions, reference_arrays))
    if record.step_times:
        row["step_ms"] = _median_step_ms(solver, record.timing_steps)
    solver.clear_load()
    row["case_ms"] = 1e3 * (time.perf_counter() - start)
    return {"row": row, "field": (positions - rest).astype(np.float32) if record.field else None}


def _median_step_ms(solver, count: int) -> float:
    """The median wall time [ms] of ``count`` steps from the equilibrium, under the loads acting there."""
    times = []
    for _ in range(count):
        begin = time.perf_counter()
        solver.step()
        times.append(time.perf_counter() - begin)
    return 1e3 * float(np.median(times))
