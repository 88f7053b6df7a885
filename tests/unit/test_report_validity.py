"""The report's account of linear elasticity's validity: per model where it fails, and what a reader should make of
the numbers then (what they still mean, what to run instead)."""

import copy

from test_experiments_outputs import synthetic_results

from tissuesim.experiments import report


def with_sizes(data: dict, size_m: float) -> dict:
    """``data`` with every model ``size_m`` [m] across and the reference moving a node 20 mm per newton."""
    data = copy.deepcopy(data)
    for info in data["metadata"]["models"].values():
        info["size_m"] = size_m
    for record in data["records"]:
        if record["method"] == "fem":
            record["max_displacement_mm"] = 20.0 * record["force_N"]
    return data


def test_cases_beyond_validity_are_counted_and_the_reader_told_what_follows():
    # 0.3 m models: 0.1 of the size is 30 mm, so 1 N (20 mm) is valid and 10 N (200 mm) is not, in each load
    text = report.report_markdown(with_sizes(synthetic_results(), 0.3))
    assert "cube: linear elasticity is not valid in 2 of 4 cases" in text
    assert "tension from 10 N, pressure from 10 N (worst: 0.67 sizes" in text
    follows = next(line for line in text.splitlines() if "**What follows.**" in line)
    assert "In 4 of 8 cases" in follows
    assert "compare the methods with one another under the same linear model" in follows
    assert "`tissuesim experiment --material neo-hookean`" in follows
    assert "`tissuesim experiment --protocol contact`" in follows
    verdict = text.split("## Verdict")[1].split("##")[0]
    assert "Linear elasticity holds in 4 of 8 cases" in verdict and "--material neo-hookean" in verdict


def test_nothing_follows_where_linear_elasticity_holds():
    text = report.report_markdown(with_sizes(synthetic_results(), 3.0))  # 0.1 of 3 m: 300 mm, above 200 mm
    assert "linear elasticity holds." in text
    assert "What follows" not in text and "Linear elasticity holds in" not in text


def test_a_finite_strain_run_gets_no_linear_verdict():
    data = with_sizes(synthetic_results(), 0.3)
    data["metadata"]["options"]["material"] = "neo-hookean"
    text = report.report_markdown(data)
    assert "Linear elasticity holds in" not in text and "What follows" not in text
