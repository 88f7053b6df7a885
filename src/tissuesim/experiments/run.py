"""The sweep of §8.3: every model × load case × method, measured on the same footing, into one results document.

Per model one :class:`~tissuesim.mesh.hybrid.HybridMesh` (with the fine reference volume) is built once; per method
one solver is made from it with its calibrated defaults; per load case

* ``solve_static(load_node, force)`` gives the quasi-static M_S positions; its wall time is ``equilibrium_ms``;
* eq 25 over the 10 plot samples and eq 26 over the 50 RMSE samples against ``fem`` are computed;
* ``step_ms`` is the median wall time of ``timing_steps`` calls of ``step(dt)`` with the load set, after
  ``warmup_steps`` untimed calls (Numba compilation and caches out of the way). All methods run in the same
  process, one after the other, so their times compare.

Results are deterministic (timings aside): nothing here is random and the order of work is fixed.

Recompute the regression reference numbers (tests/regression/experiment_reference.json) with::

    python -m tissuesim.experiments.run --write-reference tests/regression/experiment_reference.json
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import InversionError, SolverError, TissuesimError
from ..fem.hyperelastic import check_material
from ..io import SURFACE_EXTENSIONS
from ..mesh import models as builtin_models
from . import protocol
from .inputs import (builtin_surface, check_fine_volume, check_free_node, check_model_names, check_resolution,
                     model_name)
from .schema import SCHEMA_VERSION, check_results

# The reduced sweep of ``--quick``: coarser models, two forces (one small, one large deformation), fewer steps.
QUICK_RESOLUTION = 400
QUICK_FORCES_N = (1.0, 10.0)
QUICK_MAX_STEPS = 500


@dataclass(frozen=True)
class ExperimentConfig:
    """What to run. Keyword-only; every field has the paper's default.

    Attributes:
        models: built-in model names (cube, sphere, liver, steak), surface file paths, or saved bundle paths.
        forces: load magnitudes [N].
        loads: load kinds, from :data:`protocol.LOADS`.
        methods: solver names; must include :data:`protocol.REFERENCE` (``fem``) for the RMSE.
        resolution: surface vertices of the built-in models (None: the Table-1 size).
        scale: factor from a surface file's unit to metres (e.g. 0.01 for cm); a built-in model is scaled alike,
            a saved bundle (in metres) is not.
        repair: let :func:`tissuesim.read_surface` fix what it safely can in a surface file (e.g. inward faces).
        dt: time step of the timed steps [s]; None: each solver's own default (0.01 s, 100 Hz).
        warmup_steps: untimed steps before timing.
        timing_steps: timed steps per case and method (the median is reported).
        max_steps: cap on the steps of one quasi-static solve (10 s of simulated time at 0.01 s). A solver that
            has not settled by then is recorded with its last positions and ``converged: false`` rather than
            stopping the whole sweep; the report lists such cases.
        solver_options: per-method keyword options for ``make_solver`` (default: the calibrated defaults).
        material: ``"linear"`` (the paper's) or a finite-strain material (:data:`tissuesim.fem.hyperelastic.MATERIALS`)
            for every method that has it, the ``fem`` reference included; the others run as they are. With a
            finite-strain material a pressure case beyond the stable dead-load range
            (:func:`tissuesim.solvers.finite_strain.check_dead_press`) is not run; the model's metadata lists it
            under ``beyond_stable_press`` with the largest stable load.
        point_load_levels: refinement levels of the single-node load's reference measured per model to show that
            it diverges (:func:`.reference.point_load_divergence`); 0 skips it.
    """

    models: tuple = tuple(builtin_models.MODELS)
    forces: tuple = protocol.FORCES_N
    loads: tuple = protocol.LOADS
    methods: tuple = protocol.METHODS
    resolution: int | None = None
    scale: float = 1.0
    repair: bool = False
    dt: float | None = None
    warmup_steps: int = 5
    timing_steps: int = 30
    max_steps: int = 1000
    solver_options: dict = field(default_factory=dict)
    point_load_levels: int = 3
    material: str = "linear"

    def __post_init__(self):
        if not self.models:
            raise SolverError("no models given; name a built-in model (cube, sphere, liver, steak) or a mesh file")
        unknown = [m for m in self.methods if m not in protocol.METHODS]
        if unknown:
            raise SolverError(f"unknown methods {', '.join(unknown)}; choose from {', '.join(protocol.METHODS)}")
        if protocol.REFERENCE not in self.methods:
            raise SolverError(f"methods must include the reference {protocol.REFERENCE!r} to compute the RMSE")
        bad_loads = [load for load in self.loads if load not in protocol.LOAD_DIRECTIONS]
        if bad_loads or not self.loads:
            raise SolverError(f"loads must be among {', '.join(protocol.LOADS)}, got {', '.join(self.loads) or 'none'}")
        protocol.load_cases(self.forces, self.loads)  # validates the forces
        if self.dt is not None and not (self.dt > 0 and np.isfinite(self.dt)):
            raise SolverError(f"dt must be a positive number of seconds, got {self.dt!r}")
        if self.max_steps < 1:
            raise SolverError(f"max_steps must be at least 1, got {self.max_steps}")
        check_material(self.material)
        if self.warmup_steps < 0 or self.timing_steps < 1:
            raise SolverError(f"need warmup_steps ≥ 0 and timing_steps ≥ 1, got {self.warmup_steps}, "
                              f"{self.timing_steps}")
        if not (self.scale > 0 and np.isfinite(self.scale)):
            raise SolverError(f"scale must be a positive factor to metres, got {self.scale!r}")
        if self.resolution is not None:
            check_resolution(self.resolution)

    @classmethod
    def quick(cls, **overrides) -> "ExperimentConfig":
        """The CI-sized smoke sweep: resolution 400, forces 1 and 10 N, few timed steps, at most 500 steps a solve."""
        settings = dict(resolution=QUICK_RESOLUTION, forces=QUICK_FORCES_N, warmup_steps=2, timing_steps=5,
                        max_steps=QUICK_MAX_STEPS, point_load_levels=2)
        settings.update(overrides)
        return cls(**settings)

    def with_(self, **changes) -> "ExperimentConfig":
        return replace(self, **changes)


def load_model(spec: str, config: ExperimentConfig, *, progress: bool = False):
    """The :class:`HybridMesh` (with fine volume) of a built-in name, a surface file, or a saved bundle."""
    from ..mesh.hybrid import HybridMesh

    if spec in builtin_models.MODELS:
        surface = builtin_surface(spec, resolution=config.resolution, scale=config.scale)
        return HybridMesh.build(surface, fine_volume=True, progress=progress)
    path = Path(spec)
    if not path.exists():
        raise FileNotFoundError(f"{spec!r} is neither a built-in model ({', '.join(builtin_models.MODELS)}) "
                                "nor an existing file")
    if path.suffix.lower() in SURFACE_EXTENSIONS:     # anything else given by path is a saved bundle
        from ..io import read_surface

        surface = read_surface(path, scale=config.scale, repair=config.repair)
        return HybridMesh.build(surface, fine_volume=True, progress=progress)
    hybrid = HybridMesh.load(path)
    check_fine_volume(hybrid, spec)
    return hybrid


def run_experiment(config: ExperimentConfig | None = None, *, progress: bool = True, meshes: dict | None = None):
    """Run the sweep; return the results document (a JSON-ready dict, see :mod:`.schema`).

    Args:
        config: what to run (default: the paper's full sweep).
        progress: show a tqdm progress bar on stderr.
        meshes: optional ``{model spec: HybridMesh}`` already built (skips the build of those models).
    """
    from tqdm import tqdm

    from ..solvers import make_solver

    config = config or ExperimentConfig()
    wall_start = time.perf_counter()
    cases = protocol.load_cases(config.forces, config.loads)
    # Reference first, so every other method's RMSE can be computed as soon as it is solved.
    methods = [protocol.REFERENCE] + [m for m in config.methods if m != protocol.REFERENCE]
    check_model_names(config.models)
    names = [model_name(spec) for spec in config.models]
    records, model_info = [], {}
    bar = tqdm(total=len(config.models) * len(methods) * len(cases), desc="experiment", unit="case",
               file=sys.stderr, disable=not progress, dynamic_ncols=True)
    try:
        for spec, name in zip(config.models, names):
            bar.set_postfix_str(f"{name}: building")
            start = time.perf_counter()
            hybrid = (meshes or {}).get(spec) or load_model(spec, config)
            build_s = time.perf_counter() - start
            rest = np.array(hybrid.surface.vertices, dtype=np.float64)
            node = protocol.load_node(rest, hybrid.surface.triangles)
            plot_nodes = protocol.sample_nodes(rest, node, min(protocol.PLOT_SAMPLES, len(rest)))
            rmse_nodes = protocol.sample_nodes(rest, node, min(protocol.RMSE_SAMPLES, len(rest)))
            model_info[name] = _mesh_info(hybrid, spec, node, plot_nodes, rmse_nodes, build_s)
            if config.point_load_levels:
                from .reference import point_load_divergence

                bar.set_postfix_str(f"{name}: point-load refinement")
                model_info[name]["point_load_refinement"] = point_load_divergence(
                    hybrid, node, levels=config.point_load_levels)
            reference = {}
            model_cases = cases
            for method in methods:
                bar.set_postfix_str(f"{name}: {method}")
                solver = make_solver(method, hybrid, **_options(method, config))
                check_free_node(solver, node, name, role="the experiments' load at its top centre")
                if method == protocol.REFERENCE:
                    model_cases = _stable_cases(solver, cases, node, model_info[name])
                    bar.total -= (len(cases) - len(model_cases)) * len(methods)
                for case in model_cases:
                    try:
                        record = _measure(solver, case, node, config)
                    except SolverError as error:
                        raise SolverError(f"{name}: {method} cannot carry {case.label}: {_defect(error)}; give "
                                          "smaller --forces (the run stops here, nothing is written)") from None
                    positions = record.pop("positions")
                    if method == protocol.REFERENCE:
                        reference[case] = positions
                    target = reference[case]
                    records.append({
                        "model": name, "load": case.load, "force_N": float(case.force_N), "method": method,
                        "rmse_mm": 1e3 * protocol.rmse(positions, target, rmse_nodes),
                        "relative_rmse": _finite_or_none(protocol.relative_rmse(positions, target, rest, rmse_nodes)),
                        "step_ms": record["step_ms"], "equilibrium_ms": record["equilibrium_ms"],
                        "equilibrium_steps": record["equilibrium_steps"], "converged": record["converged"],
                        "displacements_mm": [float(d) for d in 1e3 * protocol.displacements(positions, rest,
                                                                                            plot_nodes)],
                        "max_displacement_mm": float(1e3 * np.linalg.norm(positions - rest, axis=1).max()),
                        **inverted_elements(solver),
                    })
                    bar.update(1)
                model_info[name].setdefault("solver_parameters", {})[method] = _solver_parameters(method, solver)
    finally:
        bar.close()
    records.sort(key=_record_order(names, config.loads, methods))
    metadata = _metadata(config, model_info)
    metadata["wall_s"] = round(time.perf_counter() - wall_start, 2)
    data = {"schema": SCHEMA_VERSION, "metadata": metadata, "records": records}
    check_results(data)
    return data


def _options(method: str, config: ExperimentConfig) -> dict:
    """``make_solver`` options of ``method``: its ``solver_options``, and the material where the method has it."""
    from ..solvers import solver_class

    options = dict(config.solver_options.get(method, {}))
    if config.material in solver_class(method).materials:
        options.setdefault("material", config.material)
    return options


def inverted_elements(solver) -> dict:
    """``{"inverted_elements": count}`` of a finite-strain solver's volume after its solve (none for linear)."""
    from ..solvers.finite_strain import inverted_element_count

    count = inverted_element_count(solver)
    return {} if count is None else {"inverted_elements": count}


def _stable_cases(reference, cases: list, node: int, info: dict) -> list:
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


def _defect(error: SolverError) -> str:
    """What went wrong, from a solver's message, without its advice to a programmer (calls a command-line user cannot
    make): the text before its first semicolon."""
    return str(error).split(";", 1)[0]


def _measure(solver, case: protocol.LoadCase, node: int, config: ExperimentConfig) -> dict:
    """Equilibrium positions and time, then the median step time with the load set, of one solver in one case."""
    force = case.vector
    solver.reset()
    solver.last_solve = None
    start = time.perf_counter()
    try:
        positions = np.array(solver.solve_static(node, force, max_steps=config.max_steps), dtype=np.float64)
    except SolverError:
        # Not settled within max_steps, or turned inside out (mass-spring): keep the last (finite) positions and
        # say so; anything else is re-raised.
        report = solver.last_solve
        if report is None or report.converged or not np.all(np.isfinite(solver.positions)):
            raise
        positions = np.array(solver.positions, dtype=np.float64)
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


def _record_order(names, loads, methods):
    model_rank = {n: i for i, n in enumerate(names)}
    load_rank = {n: i for i, n in enumerate(loads)}
    method_rank = {n: i for i, n in enumerate(protocol.METHODS)}
    return lambda r: (model_rank[r["model"]], load_rank[r["load"]], r["force_N"], method_rank[r["method"]])


def _finite_or_none(value: float):
    return float(value) if np.isfinite(value) else None


def _mesh_info(hybrid, spec, node, plot_nodes, rmse_nodes, build_s) -> dict:
    """Table-1 figures of a model's meshes plus the protocol's nodes."""

    def sizes(mesh, cells):
        if mesh is None:
            return None
        points, elements = getattr(mesh, "vertices", None), getattr(mesh, cells)
        points = mesh.points if points is None else points
        # Size as stored in memory (float64 coordinates + int32 indices) [kB]; the paper's are file sizes.
        return {"nodes": int(len(points)), "elements": int(len(elements)),
                "size_kB": round((points.nbytes + elements.nbytes) / 1024.0, 1)}

    rest = hybrid.surface.vertices
    return {
        "source": spec,
        "surface": sizes(hybrid.surface, "triangles"),
        "coarse_surface": sizes(hybrid.coarse_surface, "triangles"),
        "volume": sizes(hybrid.volume, "tets"),
        "fine_volume": sizes(hybrid.fine_volume, "tets"),
        "control_nodes": int(len(hybrid.control)),
        "fixed_nodes": int(len(protocol.fixed_nodes(rest))),
        "load_node": int(node),
        "load_node_position_m": [float(x) for x in rest[node]],
        "plot_samples": [int(i) for i in plot_nodes],
        "rmse_samples": [int(i) for i in rmse_nodes],
        "rmse_sample_radius_mm": float(1e3 * np.linalg.norm(rest[rmse_nodes] - rest[node], axis=1).max()),
        "size_m": float(np.linalg.norm(np.ptp(rest, axis=0))),
        "build_s": round(build_s, 3),
    }


def _solver_parameters(method: str, solver) -> dict:
    """The scalar values a solver holds for its keyword options (calibrated values included)."""
    from ..solvers import solver_options

    values = {}
    for option in solver_options(method):
        value = getattr(solver, option, None)
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, (int, float, str, bool)):
            values[option] = value
    return values


def _metadata(config: ExperimentConfig, model_info: dict) -> dict:
    from .. import __version__

    packages = {}
    for name in ("numpy", "scipy", "numba", "tetgen", "meshio", "matplotlib"):
        try:
            packages[name] = __import__(name).__version__
        except Exception:  # a missing optional package is reported as absent, not fatal
            packages[name] = None
    options = asdict(config)
    options["models"] = list(config.models)
    return {
        "tissuesim": __version__,
        "python": platform.python_version(),
        "packages": packages,
        "machine": {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
                    "cpus": os.cpu_count()},
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "options": json.loads(json.dumps(options, default=list)),
        "models": model_info,
    }


# --- regression reference --------------------------------------------------------------------------------------

# The small sweep whose figures tests/regression/experiment_reference.json stores.
REFERENCE_MODEL = "cube"
REFERENCE_RESOLUTION = 400
REFERENCE_FORCES_N = (1.0, 10.0)


def reference_config() -> ExperimentConfig:
    """The regression sweep: one small model, both loads, two forces, every method, few timed steps."""
    return ExperimentConfig(models=(REFERENCE_MODEL,), resolution=REFERENCE_RESOLUTION, forces=REFERENCE_FORCES_N,
                            warmup_steps=1, timing_steps=2, point_load_levels=0)


def reference_numbers(results: dict) -> dict:
    """The deterministic figures of a results document (no timings): RMSE and displacements per record."""
    return {
        "config": {"model": REFERENCE_MODEL, "resolution": REFERENCE_RESOLUTION, "forces": list(REFERENCE_FORCES_N)},
        "records": [{k: r[k] for k in ("model", "load", "force_N", "method", "rmse_mm", "relative_rmse",
                                       "displacements_mm")} for r in results["records"]],
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Recompute the stored regression reference of the experiments.")
    parser.add_argument("--write-reference", metavar="JSON", required=True, type=Path,
                        help="where to write the reference numbers (tests/regression/experiment_reference.json)")
    args = parser.parse_args(argv)
    try:
        numbers = reference_numbers(run_experiment(reference_config(), progress=True))
    except TissuesimError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    args.write_reference.write_text(json.dumps(numbers, indent=1) + "\n")
    print(f"wrote {len(numbers['records'])} reference records to {args.write_reference}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
