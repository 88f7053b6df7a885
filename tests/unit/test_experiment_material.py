"""The paper protocol with a finite-strain material: the reference is finite-strain too, presses beyond the stable
dead-load range are listed instead of run, and the report states the finite-strain run's own validity."""

import pytest

from tissuesim.cli import main
from tissuesim.errors import MaterialError
from tissuesim.experiments.report import report_markdown
from tissuesim.experiments.run import ExperimentConfig, run_experiment


@pytest.fixture(scope="module")
def finite_run():
    config = ExperimentConfig(models=("cube",), resolution=400, forces=(1.0,), methods=("fem", "embedded"),
                              material="neo-hookean", warmup_steps=0, timing_steps=1, point_load_levels=0)
    return run_experiment(config, progress=False)


def test_presses_beyond_the_stable_range_are_listed_not_run(finite_run):
    loads = {(r["load"], r["method"]) for r in finite_run["records"]}
    assert loads == {("tension", "fem"), ("tension", "embedded")}
    beyond = finite_run["metadata"]["models"]["cube"]["beyond_stable_press"]
    assert [(b["load"], b["force_N"]) for b in beyond] == [("pressure", 1.0)]
    assert "μ" in beyond[0]["reason"]


def test_the_reference_and_the_method_ran_finite_strain(finite_run):
    for record in finite_run["records"]:
        assert record["inverted_elements"] == 0
    parameters = finite_run["metadata"]["models"]["cube"]["solver_parameters"]
    assert parameters["fem"]["material"] == parameters["embedded"]["material"] == "neo-hookean"


def test_the_report_gives_the_finite_strain_validity_instead_of_the_linear_one(finite_run):
    report = report_markdown(finite_run)
    assert "## Validity of the neo-hookean runs" in report
    assert "Validity of linear elasticity" not in report
    assert "not run, beyond the stable dead-load range" in report
    assert "reference is finite-strain FEM (neo-hookean)" in report and "reference is linear FEM" not in report
    assert "RMSE per newton of the linear methods" not in report


def test_an_unknown_material_is_refused_up_front(tmp_path, capsys):
    with pytest.raises(MaterialError, match="unknown material 'rubber'"):
        ExperimentConfig(material="rubber")
    assert main(["experiment", "cube", "--material", "rubber", "--output", str(tmp_path / "out")]) != 0
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "unknown material 'rubber'" in error
    assert not (tmp_path / "out").exists()


def test_the_contact_protocol_refuses_a_finite_strain_material_it_has_no_references_for(tmp_path, capsys):
    assert main(["experiment", "--protocol", "contact", "--material", "neo-hookean", "--output",
                 str(tmp_path / "out")]) != 0
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "paper protocol only" in error
    assert not (tmp_path / "out").exists()
