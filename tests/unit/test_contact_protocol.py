"""The contact protocol: metrics by hand, a small run end to end (records, roles, convergence table, report, CLI)."""

import json

import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.experiments import contact_protocol
from tissuesim.experiments.contact_report import contact_report_markdown, method_table, ratio_table
from tissuesim.experiments.output import write_contact_outputs
from tissuesim.experiments.reference import RefinementSettings
from tissuesim.solvers import method_names

#: The methods whose answer is linear in the load (mass-spring, which is not, is also the slowest to settle).
LINEAR = method_names(where=lambda cls: cls.linear_in_load)
#: The methods whose step is the static answer: the cheapest runs.
STATIC = method_names(where=lambda cls: cls.static_by_default())


def test_metrics_by_hand():
    rest = np.zeros((4, 3))
    reference = np.array([[0, 0, -2.0], [0, 0, -1.0], [0, 0, -1.0], [0, 0, 0.0]]) * 1e-3
    positions = reference + np.array([[0, 0, 1.0], [0, 0, -1.0], [0, 0, 0.0], [0, 0, 2.0]]) * 1e-3
    m = contact_protocol.contact_metrics(positions, reference, rest, [0, 1, 2, 3], [0, 1], [0.75, 0.25])
    assert m["rmse_mm"] == pytest.approx(np.sqrt((1 + 1 + 0 + 4) / 4))
    assert m["rmse_outside_mm"] == pytest.approx(np.sqrt((0 + 4) / 2))
    assert m["contact_error_mm"] == pytest.approx(abs(0.75 * 1.0 - 0.25 * 1.0))
    assert m["reference_rms_mm"] == pytest.approx(np.sqrt((4 + 1 + 1 + 0) / 4))
    assert m["relative_rmse"] == pytest.approx(m["rmse_mm"] / m["reference_rms_mm"])
    assert m["relative_contact_error"] == pytest.approx(m["contact_error_mm"] / m["reference_rms_mm"])
    covered = contact_protocol.contact_metrics(positions, reference, rest, [0, 1], [0, 1], [0.5, 0.5])
    assert covered["rmse_outside_mm"] is None and covered["relative_rmse_outside"] is None


def test_roles():
    assert contact_protocol.role("cube", "pressure", 1.0, 4.0) == "calibration"
    assert contact_protocol.role("cube", "tension", 1.0, 4.0) == "held out"
    assert contact_protocol.role("liver", "pressure", 1.0, 4.0) == "held out"


@pytest.fixture(scope="module")
def small_run():
    config = contact_protocol.ContactConfig(models=("cube",), resolution=400, forces=(1.0, 2.0), loads=("pressure",),
                                   radii_mm=(8.0,), methods=(*LINEAR, "hybrid-near"),
                                   settings=RefinementSettings(max_levels=1))
    return contact_protocol.run_contact(config, progress=False)


def reference_change(run) -> float:
    """The last level change of the small run's reference (it stops at level 1, unconverged)."""
    return run["metadata"]["models"]["cube"]["references"]["8"]["levels"][-1]["change"]


def test_small_run_records_and_metrics(small_run, better_beyond_the_reference):
    records = small_run["records"]
    assert len(records) == 2 * 5  # two forces × five methods
    for r in records:
        assert r["role"] == "held out" and r["radius_mm"] == 8.0  # exact: the option
        for key in ("rmse", "rmse_outside", "contact_error"):
            assert r[f"{key}_mm"] > 0 and r[f"relative_{key}"] == pytest.approx(r[f"{key}_mm"] / r["reference_rms_mm"])
    by = {(r["method"], r["force_N"]): r for r in records}
    # Every method here is linear: twice the force, twice every error; the relative errors stay.
    for method in LINEAR:
        assert by[(method, 2.0)]["rmse_mm"] == pytest.approx(2 * by[(method, 1.0)]["rmse_mm"], rel=1e-6)
        assert by[(method, 2.0)]["relative_rmse"] == pytest.approx(by[(method, 1.0)]["relative_rmse"], rel=1e-6)
    levels = small_run["metadata"]["models"]["cube"]["references"]["8"]["levels"]
    assert [row["level"] for row in levels] == [0, 1]
    # The default fine mesh's error is well below the embedded surface's, by more than the reference is unsure of.
    relative = {key: r["relative_rmse"] for key, r in by.items()}
    better_beyond_the_reference(relative, "fem", "embedded", reference_change(small_run))


def test_the_near_field_beats_the_paper_hybrid_and_the_ratios_are_reported(small_run, better_beyond_the_reference):
    by = {(r["method"], r["force_N"]): r["relative_rmse"] for r in small_run["records"]}
    # Measured: a gap of 0.16 against a reference change of 0.055. The hybrid's lead on the embedded surface here
    # (0.046) is within the one-level reference's uncertainty, so it is not asserted on it.
    better_beyond_the_reference(by, "hybrid-near", "hybrid", reference_change(small_run))
    table = ratio_table(small_run)
    rows = {line.split(" | ")[0].strip("| "): line.split(" | ") for line in table.splitlines()[2:]}
    assert set(rows) == {"Ours", "Ours+NF"} and rows["Ours"][1] == "2"
    assert float(rows["Ours+NF"][2].split(" / ")[0]) < float(rows["Ours"][2].split(" / ")[0])


def test_report_prints_convergence_table_and_method_table(small_run, tmp_path):
    text = contact_report_markdown(small_run)
    assert "### cube, R = 8 mm" in text and "| Level | Tets |" in text
    assert "not converged" in text  # one level cannot reach 1 %
    table = method_table(small_run)
    assert table.splitlines()[0].startswith("| Method | Rows |") and "Emb." in table and "FEM" in table
    paths = write_contact_outputs(small_run, tmp_path / "out")
    assert sorted(p.name for p in paths) == ["errors.png", "report.md", "results.json"]
    from matplotlib.image import imread

    image = imread(tmp_path / "out" / "errors.png")
    assert image.shape[0] > 300 and image.shape[1] > 600 and image[..., :3].std() > 0.05   # drawn, not blank
    assert json.loads((tmp_path / "out" / "results.json").read_text())["schema"] == contact_protocol.SCHEMA


def test_cli_contact_protocol(tmp_path, capsys):
    code = main(["experiment", "cube", "--protocol", "contact", "--resolution", "400", "--forces", "1",
                 "--loads", "tension", "--radii", "8", "--methods", *STATIC, "--levels", "1",
                 "--cache", str(tmp_path / "cache"), "--output", str(tmp_path / "out"), "--quiet"])
    assert code == 0
    assert (tmp_path / "out" / "report.md").is_file() and list((tmp_path / "cache").glob("*.npz"))


@pytest.mark.parametrize("arguments, message", [
    (["--protocol", "magic"], "unknown protocol 'magic'"),
    (["--protocol", "contact", "--radii", "-1"], "--radii takes a positive"),
    (["--protocol", "contact", "--levels", "1.5"], "--levels takes a positive whole number"),
    (["--protocol", "contact", "--methods", "hybrid-far"], "unknown contact protocol method(s) 'hybrid-far'; "
                                                          "choose from hybrid, pbd"),
])
def test_bad_contact_argument_is_a_one_line_error(arguments, message, tmp_path, capsys):
    code = main(["experiment", *arguments, "--output", str(tmp_path / "out"), "--quiet"])
    error = capsys.readouterr().err
    assert code == 1 and message in error and error.count("\n") == 1


def test_paper_report_shows_the_single_node_load_diverging():
    from tissuesim.experiments.report import report_markdown
    from tissuesim.experiments.run import run_experiment
    from tissuesim.experiments.sweep_config import ExperimentConfig

    data = run_experiment(ExperimentConfig.quick(models=("cube",), forces=(1.0,), loads=("pressure",),
                                                 methods=STATIC), progress=False)
    levels = data["metadata"]["models"]["cube"]["point_load_refinement"]
    assert [row["level"] for row in levels] == [0, 1, 2]
    assert levels[2]["contact_mm"] > 3 * levels[0]["contact_mm"]  # h_c / 4: the loaded node's value keeps growing
    text = report_markdown(data)
    assert "## The single-node load's reference diverges" in text and "| cube | 2 |" in text


def test_a_radius_reaching_the_support_is_skipped_before_its_reference(tmp_path):
    config = contact_protocol.ContactConfig(models=("cube",), resolution=400, forces=(1.0,), loads=("pressure",),
                                   radii_mm=(1e6,), methods=("embedded",), cache_dir=str(tmp_path),
                                   settings=RefinementSettings(max_levels=1))
    run = contact_protocol.run_contact(config, progress=False)
    cube = run["metadata"]["models"]["cube"]
    assert run["records"] == [] and "fixed region" in cube["skipped"]["1e+06"]
    assert cube["references"] == {} and len(cube["samples"]) == 50
    assert not any(tmp_path.iterdir())      # no reference was computed or cached
    assert "Skipped: cube, R = 1e+06 mm" in contact_report_markdown(run)
