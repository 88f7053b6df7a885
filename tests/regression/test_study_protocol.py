"""The paper's protocol through ``tissuesim study`` gives ``tissuesim experiment``'s numbers: the same load node,
the same 50 RMSE samples, the same fem reference, so the same RMSE (eq 26) to round-off."""

from pathlib import Path

import pytest

from tissuesim.experiments.run import run_experiment
from tissuesim.experiments.sweep_config import ExperimentConfig
from tissuesim.study.cases import expand
from tissuesim.study.load import read_study
from tissuesim.study.runner import run_study
from tissuesim.study.store import Store

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "studies" / "paper_protocol_quick.toml"


def test_the_quick_paper_protocol_reproduces_the_experiment(tmp_path):
    cases = expand(read_study(EXAMPLE))
    store = Store(tmp_path / "out")
    summary = run_study(cases, store, progress=False)
    assert summary.failed == 0
    studied = {(r["model"], "tension" if r["direction_z"] > 0 else "pressure", r["force_N"], r["method"]): r
               for r in store.combine().to_pylist()}
    methods = tuple(sorted({key[3] for key in studied})) + ("fem",)
    document = run_experiment(ExperimentConfig.quick(models=("cube",), methods=methods, point_load_levels=0),
                              progress=False)
    compared = 0
    for record in document["records"]:
        key = (record["model"], record["load"], record["force_N"], record["method"])
        if key in studied:
            compared += 1
            # the same arithmetic on the same arrays: equal to a relative 1e-12 (round-off of another run order)
            assert 1e3 * studied[key]["rmse_m"] == pytest.approx(record["rmse_mm"], rel=1e-12)
            assert studied[key]["relative_rmse"] == pytest.approx(record["relative_rmse"], rel=1e-12)
    assert compared == len(cases) == 16


CONTACT = EXAMPLE.with_name("contact_protocol_quick.toml")


def test_the_quick_contact_protocol_reproduces_the_experiment(tmp_path):
    from tissuesim.experiments.contact_protocol import METRICS, QUICK, ContactConfig, run_contact

    store = Store(tmp_path / "out")
    assert run_study(expand(read_study(CONTACT)), store, progress=False).failed == 0
    studied = {}
    for row in store.combine().to_pylist():
        variants = [name for key, name in (("near_field", "hybrid-near"), ("element", "hybrid-quadratic"))
                    if key in row["options"]]     # the options as the store keeps them (JSON text)
        method = variants[0] if variants else row["method"]
        studied[(method, "tension" if row["direction_z"] > 0 else "pressure", row["force_N"])] = row
    records = run_contact(ContactConfig(**QUICK), progress=False)["records"]
    assert len(records) == len(studied) == 28
    for record in records:
        row = studied[(record["method"], record["load"], record["force_N"])]
        assert (row["converged"], row["reference_converged"]) == (record["converged"], record["reference_converged"])
        for metric in METRICS:
            assert 1e3 * row[f"{metric}_m"] == pytest.approx(record[f"{metric}_mm"], rel=1e-12)
            assert row[f"relative_{metric}"] == pytest.approx(record[f"relative_{metric}"], rel=1e-12)
