"""Sweep item 16: a linear model pushed past its validity says so, in the solve report and the experiment report."""

import numpy as np

from tissuesim import make_solver
from tissuesim.experiments.report import report_markdown


def test_solve_static_reports_where_linear_elasticity_is_not_valid(small_cube, small_cube_size):
    solver = make_solver("fem", small_cube)
    corner = int(np.argmax(small_cube.surface.vertices.sum(axis=1)))
    solver.solve_static(corner, [0.0, 0.0, 20.0])
    assert solver.last_solve.largest_displacement > small_cube_size      # the corner moves more than the cube
    assert "linear elasticity is not valid here" in solver.last_solve.warning
    solver.solve_static(corner, [0.0, 0.0, 0.01])
    assert solver.last_solve.linear_valid and solver.last_solve.warning is None


def test_the_experiment_report_names_the_cases_beyond_validity(synthetic_results):
    data = synthetic_results(models=("cube",), forces=(1.0, 10.0))
    data["metadata"]["models"]["cube"]["size_m"] = 0.1
    for record in data["records"]:
        record["max_displacement_mm"] = 3.0 * record["force_N"]      # 30 mm at 10 N: 0.3 of the size
    text = report_markdown(data)
    assert "linear elasticity is not valid in 2 of 4 cases" in text
    assert "tension from 10 N, pressure from 10 N" in text
