"""The experiment on a small model: method ordering by RMSE, linear scaling with force, stored reference numbers,
and the quick CLI run writing every output.

The stored numbers (experiment_reference.json beside this file) are recomputed by::

    python -m tissuesim.experiments.run --write-reference tests/regression/experiment_reference.json
"""

import json
from pathlib import Path

import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.experiments import protocol
from tissuesim.experiments.run import load_model, reference_config, reference_numbers, run_experiment
from tissuesim.experiments.schema import check_results
from tissuesim.solvers import make_solver

REFERENCE_FILE = Path(__file__).with_name("experiment_reference.json")
# Relative tolerance on stored RMSE and displacements: the sweep is deterministic; this absorbs BLAS/SuperLU
# round-off and iterative solvers stopping one step apart on another machine.
RTOL = 2e-3
ATOL_MM = 1e-4


@pytest.fixture(scope="module")
def hybrid():
    config = reference_config()
    return load_model(config.models[0], config)


@pytest.fixture(scope="module")
def results(hybrid):
    config = reference_config()
    return run_experiment(config, progress=False, meshes={config.models[0]: hybrid})


def _by_case(results):
    table = {}
    for r in results["records"]:
        table.setdefault((r["load"], r["force_N"]), {})[r["method"]] = r
    return table


def test_results_follow_the_schema(results):
    check_results(results)
    cases = protocol.load_cases(reference_config().forces)
    assert len(results["records"]) == len(cases) * len(protocol.METHODS)
    for record in results["records"]:
        assert len(record["displacements_mm"]) == protocol.PLOT_SAMPLES
        if record["method"] == protocol.REFERENCE:
            assert record["rmse_mm"] == 0.0


def test_hybrid_beats_surface_only_pbd(results):
    """The hybrid is PBD's surface model with its control nodes held on the FEM solution: it must be closer to the
    reference than PBD in every case. (Against MSM, the paper's other claim, the outcome depends on calibration:
    it is reported in report.md and pinned by the stored ordering below, not asserted as a law.)"""
    for case, methods in _by_case(results).items():
        assert methods["hybrid"]["rmse_mm"] < methods["pbd"]["rmse_mm"], case


def test_ordering_of_methods_matches_the_stored_one(results):
    stored = json.loads(REFERENCE_FILE.read_text())
    expected = {}
    for r in stored["records"]:
        expected.setdefault((r["load"], r["force_N"]), []).append((r["rmse_mm"], r["method"]))
    for case, methods in _by_case(results).items():
        ours = [m for _, m in sorted((r["rmse_mm"], m) for m, r in methods.items())]
        assert ours == [m for _, m in sorted(expected[case])], case


def test_linear_methods_scale_linearly_with_force(results, hybrid):
    table = _by_case(results)
    small, large = sorted(reference_config().forces)[:2]
    factor = large / small
    for load in protocol.LOADS:
        for method in ("embedded", "fem"):
            a, b = table[(load, small)][method], table[(load, large)][method]
            assert np.array(b["displacements_mm"]) == pytest.approx(factor * np.array(a["displacements_mm"]),
                                                                    rel=1e-9)
        a, b = table[(load, small)]["embedded"], table[(load, large)]["embedded"]
        assert b["rmse_mm"] == pytest.approx(factor * a["rmse_mm"], rel=1e-9)
        assert b["relative_rmse"] == pytest.approx(a["relative_rmse"], rel=1e-9)
    # The hybrid's FEM part: control nodes take the coarse FEM positions, linear in the force.
    solver = make_solver("hybrid", hybrid)
    rest = np.asarray(hybrid.surface.vertices)
    node = protocol.load_node(rest, hybrid.surface.triangles)
    control = np.asarray(hybrid.control)
    u_small = solver.solve_static(node, [0.0, 0.0, -small])[control] - rest[control]
    u_large = solver.solve_static(node, [0.0, 0.0, -large])[control] - rest[control]
    assert np.abs(u_large).max() > 0
    assert u_large == pytest.approx(factor * u_small, rel=1e-6, abs=1e-12)


def test_figures_match_the_stored_reference(results):
    stored = json.loads(REFERENCE_FILE.read_text())
    ours = reference_numbers(results)
    assert ours["config"] == stored["config"]
    expected = {(r["load"], r["force_N"], r["method"]): r for r in stored["records"]}
    assert len(expected) == len(ours["records"])
    for record in ours["records"]:
        key = (record["load"], record["force_N"], record["method"])
        reference = expected[key]
        assert record["rmse_mm"] == pytest.approx(reference["rmse_mm"], rel=RTOL, abs=ATOL_MM), key
        assert record["displacements_mm"] == pytest.approx(reference["displacements_mm"], rel=RTOL, abs=ATOL_MM), key


def test_quick_cli_run_writes_every_output(tmp_path, capsys):
    output = tmp_path / "results"
    code = main(["experiment", "cube", "--quick", "--forces", "2", "--output", str(output), "--quiet"])
    assert code == 0, capsys.readouterr().err
    names = sorted(p.name for p in output.iterdir())
    assert names == ["radar_cube.png", "report.md", "results.json", "tables.md"]
    data = json.loads((output / "results.json").read_text())
    check_results(data)
    assert {r["method"] for r in data["records"]} == set(protocol.METHODS)
    assert {(r["load"], r["force_N"]) for r in data["records"]} == {("tension", 2.0), ("pressure", 2.0)}
    assert "## Table 3" in (output / "tables.md").read_text()
    assert "Winner of each row" in (output / "report.md").read_text()
