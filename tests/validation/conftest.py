"""Fixtures of the validation tests."""

import importlib.util
from pathlib import Path

import pytest

from tissuesim.solvers import available_solvers, unregister


@pytest.fixture(scope="module")
def hertz():
    """``benchmarks/hertz_reference.py``: the indentation block, Hertz's force and the quadratic-tet method that the
    benchmark and these tests share."""
    path = Path(__file__).resolve().parents[2] / "benchmarks" / "hertz_reference.py"
    spec = importlib.util.spec_from_file_location("hertz_reference", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    yield module
    if module.QUADRATIC in available_solvers():      # its method joins every list of methods: not beyond its tests
        unregister(module.QUADRATIC)
