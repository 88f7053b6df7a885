"""``tissuesim experiment``: bad arguments are one-line errors with exit status 1, before any work is done."""

import pytest

from tissuesim.cli import main
from tissuesim.experiments.sweep_config import ExperimentConfig


@pytest.mark.parametrize("arguments, message", [
    (["--forces", "abc"], "--forces takes numbers"),
    (["--forces", "1", "-2"], "--forces takes a positive"),
    (["--resolution", "12.5"], "--resolution takes a positive whole number"),
    (["--steps", "0"], "--steps takes a positive"),
    (["--scale", "nan"], "--scale takes a positive"),
    (["--methods", "hybrid", "magic"], "unknown method 'magic'"),
    (["--loads", "shear"], "loads must be among tension, pressure"),
    (["no-such-model"], "neither a built-in model"),
])
def test_bad_argument_is_a_one_line_error(arguments, message, tmp_path, capsys):
    code = main(["experiment", *arguments, "--output", str(tmp_path / "out"), "--quiet"])
    error = capsys.readouterr().err
    assert code == 1
    assert message in error
    assert error.count("\n") == 1 and error.startswith("tissuesim experiment: error:")
    assert not (tmp_path / "out").exists()


def test_output_that_is_a_file_is_refused(tmp_path, capsys):
    target = tmp_path / "results"
    target.write_text("not a folder")
    assert main(["experiment", "cube", "--quick", "--output", str(target), "--quiet"]) == 1
    assert "is a file" in capsys.readouterr().err
    assert target.read_text() == "not a folder"


def test_config_validates_its_options():
    with pytest.raises(Exception, match="reference 'fem'"):
        ExperimentConfig(methods=("hybrid",))
    with pytest.raises(Exception, match="no models"):
        ExperimentConfig(models=())
    quick = ExperimentConfig.quick()
    assert quick.resolution == 400 and len(quick.forces) < len(ExperimentConfig().forces)
