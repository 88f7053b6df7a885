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
import json
import sys
import time
from pathlib import Path

from ..errors import SolverError, TissuesimError
from . import protocol
from .inputs import check_free_node, check_model_names, model_name
from .schema import SCHEMA_VERSION, check_results
from .sweep_config import ExperimentConfig, load_model
from .sweep_measure import measure, method_options, stable_cases
from .sweep_records import ModelSamples, case_record, mesh_info, record_order, solver_parameters, sweep_metadata


def run_experiment(config: ExperimentConfig | None = None, *, progress: bool = True,
                   meshes: dict | None = None) -> dict:
    """Run the sweep; return the results document (a JSON-ready dict, see :mod:`.schema`).

    Args:
        config: what to run (default: the paper's full sweep).
        progress: show a tqdm progress bar on stderr.
        meshes: optional ``{model spec: HybridMesh}`` already built (skips the build of those models).
    """
    from tqdm import tqdm

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
            model_info[name] = _sweep_model(spec, name, config, meshes, cases, methods, bar, records)
    finally:
        bar.close()
    records.sort(key=record_order(names, config.loads))
    metadata = sweep_metadata(config, model_info)
    metadata["wall_s"] = round(time.perf_counter() - wall_start, 2)
    data = {"schema": SCHEMA_VERSION, "metadata": metadata, "records": records}
    check_results(data)
    return data


def _sweep_model(spec: str, name: str, config: ExperimentConfig, meshes: dict | None, cases: list, methods: list,
                 bar, records: list) -> dict:
    """Build one model and measure every method in its cases, appending to ``records``; return the model's
    metadata (mesh figures, point-load refinement, cases beyond the stable press, solver parameters)."""
    from ..solvers import make_solver

    bar.set_postfix_str(f"{name}: building")
    start = time.perf_counter()
    hybrid = (meshes or {}).get(spec) or load_model(spec, config)
    build_s = time.perf_counter() - start
    model = ModelSamples.of(name, hybrid)
    info = mesh_info(hybrid, spec, model, build_s)
    if config.point_load_levels:
        from .reference import point_load_divergence

        bar.set_postfix_str(f"{name}: point-load refinement")
        info["point_load_refinement"] = point_load_divergence(hybrid, model.node, levels=config.point_load_levels)
    reference = {}
    model_cases = cases
    for method in methods:
        bar.set_postfix_str(f"{name}: {method}")
        solver = make_solver(method, hybrid, **method_options(method, config))
        check_free_node(solver, model.node, name, role="the experiments' load at its top centre")
        if method == protocol.REFERENCE:
            model_cases = stable_cases(solver, cases, model.node, info)
            bar.total -= (len(cases) - len(model_cases)) * len(methods)
        for case in model_cases:
            records.append(_case(solver, method, case, model, reference, config))
            bar.update(1)
        info.setdefault("solver_parameters", {})[method] = solver_parameters(method, solver)
    return info


def _case(solver, method: str, case: protocol.LoadCase, model: ModelSamples, reference: dict,
          config: ExperimentConfig) -> dict:
    """The record of one method in one case, against the ``reference`` positions per case (which the reference
    method's own solve fills in)."""
    try:
        measured = measure(solver, case, model.node, config)
    except SolverError as error:
        raise SolverError(f"{model.name}: {method} cannot carry {case.label}: {_defect(error)}; give "
                          "smaller --forces (the run stops here, nothing is written)") from None
    positions = measured.pop("positions")
    if method == protocol.REFERENCE:
        reference[case] = positions
    return case_record(model, case, method, measured, positions, reference[case], solver)


def _defect(error: SolverError) -> str:
    """What went wrong, from a solver's message, without its advice to a programmer (calls a command-line user cannot
    make): the text before its first semicolon."""
    return str(error).split(";", 1)[0]


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
