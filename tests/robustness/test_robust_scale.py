"""Sweep item 10: ``--scale`` is checked (positive, finite) for every source, built-in models included."""

import pytest

from tissuesim import cli


@pytest.mark.parametrize("scale", ["0", "-1", "nan", "inf"])
def test_build_refuses_a_bad_scale_for_a_built_in_model(scale, capsys):
    assert cli.main(["build", "cube", "--resolution", "100", "--scale", scale]) == 1
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert "scale must be a positive finite number" in error
    assert "repair" not in error
