"""Results schema, Markdown tables, report and the all-or-nothing results folder, on synthetic results (the radar
plots: test_plots_radar.py)."""

import copy
import json

import numpy as np
import pytest

from tissuesim.experiments import output, report, tables
from tissuesim.experiments.schema import ResultsError, check_results

# Synthetic figures: method -> (RMSE per newton [mm/N], step time [ms]).
SYNTHETIC = {"hybrid": (0.05, 3.0), "pbd": (0.2, 2.0), "mass-spring": (0.3, 1.5), "embedded": (0.1, 0.5),
             "fem": (0.0, 12.0)}


def synthetic_results(models=("cube", "liver"), forces=(1.0, 10.0)) -> dict:
    records = []
    for model in models:
        for load in ("tension", "pressure"):
            for force in forces:
                for method, (per_newton, step) in SYNTHETIC.items():
                    records.append({
                        "model": model, "load": load, "force_N": force, "method": method,
                        "rmse_mm": per_newton * force, "relative_rmse": per_newton / 2.0,
                        "step_ms": step, "equilibrium_ms": 10 * step, "equilibrium_steps": 10,
                        "displacements_mm": list(np.linspace(2.0, 0.5, 10) * force * (1 + per_newton)),
                    })
    info = {"surface": {"nodes": 100, "elements": 196, "size_kB": 3.1}, "volume": {"nodes": 40, "elements": 90,
            "size_kB": 1.0}, "fine_volume": {"nodes": 150, "elements": 500, "size_kB": 5.0}}
    metadata = {"tissuesim": "0", "python": "3", "packages": {}, "date": "2026-01-01T00:00:00+00:00",
                "machine": {"platform": "test", "processor": "test-cpu", "cpus": 2}, "wall_s": 1.0,
                "options": {"forces": list(forces), "timing_steps": 5, "warmup_steps": 1},
                "models": {m: copy.deepcopy(info) for m in models}}
    return {"schema": 1, "metadata": metadata, "records": records}


# ------------------------------------------------------------------------------------------------------ schema
def test_synthetic_results_pass_the_schema():
    check_results(synthetic_results())


@pytest.mark.parametrize("damage, match", [
    (lambda d: d.pop("records"), "records"),
    (lambda d: d.update(schema=0), "schema"),
    (lambda d: d["metadata"].pop("machine"), "machine"),
    (lambda d: d["records"][3].pop("rmse_mm"), r"record 3: missing field 'rmse_mm'"),
    (lambda d: d["records"][0].update(step_ms="fast"), "step_ms"),
    (lambda d: d["records"][1].update(rmse_mm=float("nan")), "not finite"),
    (lambda d: d["records"][2].update(displacements_mm=[1.0, -1.0]), "displacements_mm"),
    (lambda d: d["records"].append(dict(d["records"][0])), "more than one record"),
])
def test_schema_names_the_defect(damage, match):
    data = synthetic_results()
    damage(data)
    with pytest.raises(ResultsError, match=match):
        check_results(data)


def test_relative_rmse_may_be_null():
    data = synthetic_results()
    data["records"][0]["relative_rmse"] = None
    check_results(data)


# ------------------------------------------------------------------------------------------------------ tables
def test_measured_ratios_are_medians_of_per_case_ratios():
    data = synthetic_results()
    odd = copy.deepcopy(data)
    for record in odd["records"]:
        if record["model"] == "cube" and record["method"] == "hybrid" and record["force_N"] == 10.0:
            record["rmse_mm"] = 1e19 if record["load"] == "tension" else 0.0  # one blow-up, one perfect case
    assert tables.measured_ratio(odd, "cube", "rmse", "hybrid", "pbd") == pytest.approx(0.25)
    assert tables.measured_ratio(data, "cube", "rmse", "hybrid", "pbd") == pytest.approx(0.25)
    assert tables.measured_ratio(data, "cube", "time", "fem", "hybrid") == pytest.approx(4.0)
    summary = tables.ratio_summary(data)
    assert summary["liver"]["Ours/MSM RMSE"][0] == pytest.approx(0.05 / 0.3)
    assert summary["cube"]["Ours/PBD step"] == (pytest.approx(1.5), pytest.approx(2.4 / 1.5, rel=0.1))


def test_tables_put_ours_beside_the_published_figures():
    text = tables.tables_markdown(synthetic_results())
    for heading in ("Table 1", "Table 2", "Table 3", "Table 4", "Table 5", "Headline ratios"):
        assert heading in text
    assert "0.0462" in text  # paper, Table 3, cube, tension 1 N, Ours
    assert "| tension | 10 N | 0.5 | 2 | 3 | 1 |" in text  # our cube RMSE row: hybrid, pbd, msm, embedded
    assert "5.5188" not in text  # liver 20 N was not run, so its published row is not shown
    assert "13" in text and "| cube | fine surface M_S | 100 | 196 |" in text


def test_tables_of_an_additional_model_have_no_paper_figures():
    text = tables.tables_markdown(synthetic_results(models=("bunny",)))
    assert "Additional model: bunny" in text and "## Table 2" not in text


# ------------------------------------------------------------------------------------------------------ report
def test_report_names_winners_and_ratios():
    data = synthetic_results()
    data["records"][0]["rmse_mm"] = 99.0  # cube tension 1 N: the hybrid now loses to everyone
    text = report.report_markdown(data)
    assert "more accurate than PBD in 7 of 8 cases" in text
    assert "| cube | tension | 1 N | Emb. | Emb. 0.1 < PBD 0.2 < MSM 0.3 < Ours 99 | Ours |" in text
    assert "| cube | tension | 10 N | Ours |" in text
    assert "hybrid costs 1.5–1.5× PBD's time" in text
    assert "Table 5 (steak)" in text  # the published tables' defects are reported


# ------------------------------------------------------------------------------------------------ plots, folder
def test_write_outputs_writes_every_file(tmp_path):
    data = synthetic_results()
    paths = output.write_outputs(data, tmp_path / "results")
    names = sorted(p.name for p in paths)
    assert names == ["radar_cube.png", "radar_liver.png", "report.md", "results.json", "tables.md"]
    assert json.loads((tmp_path / "results" / "results.json").read_text()) == data
    assert (tmp_path / "results" / "radar_cube.png").read_bytes()[:4] == b"\x89PNG"
    assert [p.name for p in tmp_path.iterdir()] == ["results"]  # no staging folder left behind


def test_write_outputs_refuses_a_file_target(tmp_path):
    target = tmp_path / "results"
    target.write_text("keep me")
    with pytest.raises(output.OutputError, match="is a file"):
        output.write_outputs(synthetic_results(), target)
    assert target.read_text() == "keep me"


def test_a_failed_write_leaves_nothing(tmp_path, monkeypatch):
    existing = tmp_path / "old"
    existing.mkdir()
    (existing / "report.md").write_text("old report")

    def broken(data, folder):
        raise RuntimeError("disk full")

    monkeypatch.setattr(output, "write_radar_plots", broken)
    for target in (tmp_path / "new", existing):
        with pytest.raises(RuntimeError):
            output.write_outputs(synthetic_results(), target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old"]
    assert [p.name for p in existing.iterdir()] == ["report.md"]
    assert (existing / "report.md").read_text() == "old report"


def test_write_outputs_refuses_malformed_results(tmp_path):
    data = synthetic_results()
    data["records"] = []
    with pytest.raises(ResultsError):
        output.write_outputs(data, tmp_path / "out")
    assert not (tmp_path / "out").exists()
