"""Both protocols with a finite-strain material: the reference is finite-strain too, presses beyond the stable
dead-load range are listed instead of run, and the report states the finite-strain run's own validity."""

import pytest

from tissuesim.cli import main
from tissuesim.errors import MaterialError, SolverError
from tissuesim.experiments import contact_protocol
from tissuesim.experiments.contact_report import contact_report_markdown
from tissuesim.experiments.report import report_markdown
from tissuesim.experiments.reference import RefinementSettings
from tissuesim.experiments.run import run_experiment
from tissuesim.experiments.sweep_config import ExperimentConfig
from tissuesim.solvers import method_names


@pytest.fixture(scope="module")
def finite_run():
    config = ExperimentConfig(models=("cube",), resolution=400, forces=(1.0,),
                              methods=method_names(where=lambda cls: cls.static_by_default()),
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


@pytest.fixture(scope="module")
def finite_contact_run():
    config = contact_protocol.ContactConfig(models=("cube",), resolution=400, forces=(1.0,), radii_mm=(8.0,),
                                   material="neo-hookean", settings=RefinementSettings(max_levels=0))
    return contact_protocol.run_contact(config, progress=False)


def test_the_contact_protocol_runs_the_methods_that_have_the_material_against_a_finite_reference(
        finite_contact_run):
    meta = finite_contact_run["metadata"]
    assert meta["material"] == "neo-hookean"
    assert set(meta["methods"]) == {*method_names(material="neo-hookean"), "hybrid-near", "hybrid-quadratic"}
    records = finite_contact_run["records"]
    assert {(r["method"], r["load"]) for r in records} == {(m, "tension") for m in meta["methods"]}
    assert all(r["inverted_elements"] == 0 and r["relative_rmse"] is not None for r in records)
    beyond = meta["models"]["cube"]["beyond_stable_press"]
    assert [(b["load"], b["force_N"], b["radius_mm"]) for b in beyond] == [("pressure", 1.0, 8.0)]
    # the fine FEM of the same material is the method nearest the finite-strain reference, as it is for linear
    errors = {r["method"]: r["relative_rmse"] for r in records}
    assert errors["fem"] == min(errors.values())


def test_the_contact_report_names_the_material_and_the_presses_it_did_not_run(finite_contact_run):
    report = contact_report_markdown(finite_contact_run)
    assert "Material: neo-hookean (finite strain)" in report
    assert "## Validity of the neo-hookean runs" in report and "1 N at R = 8 mm" in report
    assert "per newton of the largest stable load" in report


def test_a_contact_method_without_the_material_is_refused_up_front(tmp_path, capsys):
    lacking = method_names(where=lambda cls: "neo-hookean" not in cls.materials)
    with pytest.raises(SolverError, match=f"{', '.join(lacking)} ha(s|ve) no neo-hookean material; choose among "
                                          f"{', '.join(method_names(material='neo-hookean'))}"):
        contact_protocol.ContactConfig(methods=(*method_names(material="neo-hookean"), *lacking),
                                       material="neo-hookean")
    assert main(["experiment", "--protocol", "contact", "--material", "neo-hookean", "--methods", "mass-spring",
                 "--output", str(tmp_path / "out")]) != 0
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "mass-spring has no neo-hookean material" in error
    assert not (tmp_path / "out").exists()


def test_the_contact_command_runs_with_a_finite_strain_material(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["experiment", "--protocol", "contact", "--quick", "--material", "corotated", "--levels", "1",
                 "--methods", "fem", "--forces", "1", "--quiet", "--no-cache", "--output", str(out)]) == 0
    report = (out / "report.md").read_text()
    assert "Material: corotated (finite strain)" in report and "beyond the stable dead-load range" in report


def test_the_contact_figure_names_the_reference_it_was_measured_against(finite_contact_run):
    from tissuesim.experiments.contact_plots import error_figure

    title = error_figure(finite_contact_run).axes[0].get_title()
    assert "neo-hookean reference" in title and "not converged" in title    # level 0 only: nothing to compare
