"""Sweep item 15: small input defects end in a specific error, and the CLI's own text stays clean."""

import pytest

from tissuesim import MaterialError, MeshError, SolverError, cli, make_solver


def test_a_youngs_modulus_that_is_no_number_is_a_material_error(small_cube):
    with pytest.raises(MaterialError, match="youngs_modulus must be a real number, got 'abc'"):
        make_solver("embedded", small_cube, youngs_modulus="abc")


@pytest.mark.parametrize("node", [True, False])
def test_a_boolean_load_node_is_refused(small_cube, node):
    solver = make_solver("embedded", small_cube)
    with pytest.raises(SolverError, match="integer vertex index"):
        solver.set_load(node, [0.0, 0.0, 1.0])


def test_a_fractional_max_steps_is_refused(small_cube, small_cube_top):
    solver = make_solver("embedded", small_cube)
    with pytest.raises(SolverError, match="max_steps must be a whole number"):
        solver.solve_static(small_cube_top, [0.0, 0.0, 1.0], max_steps=2.5)


def test_the_top_level_help_is_plain_text(capsys):
    with pytest.raises(SystemExit):
        cli.main(["--help"])
    text = capsys.readouterr().out
    assert ":mod:" not in text and "``" not in text


def test_a_progress_bar_does_not_run_into_the_error_line(monkeypatch, capsys):
    def failing_simplify(surface, **options):
        raise MeshError("simplification failed on purpose")

    monkeypatch.setattr("tissuesim.mesh.simplify.simplify", failing_simplify)
    assert cli.main(["build", "cube", "--resolution", "100"]) == 1
    err = capsys.readouterr().err
    # What a terminal shows of the last line: the text after its last carriage return.
    shown = err.rstrip("\n").split("\n")[-1].split("\r")[-1]
    assert shown.startswith("tissuesim build: error: simplification failed on purpose")
