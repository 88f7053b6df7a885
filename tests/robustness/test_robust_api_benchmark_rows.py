"""benchmarks/finite_strain_errors.py with its own defaults: every row it solves is one its method takes (the pbd
surface has no finite-strain material), and the rows it cannot solve are labelled as skipped, saying why."""

import importlib.util
from pathlib import Path

import pytest

from tissuesim import make_solver

PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "finite_strain_errors.py"


@pytest.fixture(scope="module")
def benchmark():
    spec = importlib.util.spec_from_file_location("finite_strain_errors", PATH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("argv", [[], ["--material", "corotated"], ["--near-field"]])
def test_every_row_the_benchmark_solves_builds_its_solver(benchmark, small_cube, argv):
    args = benchmark.parse(argv)
    table = benchmark.rows(args.material, args.near_field)
    solved = [(method, options, material) for _, method, options, material, skipped in table if skipped is None]
    assert len(solved) == len(table) - 1      # the pbd's finite-strain row alone is skipped
    for method, options, material in solved:
        if "near_field" not in options:       # the near field builds its own fine window: minutes, not seconds
            make_solver(method, small_cube, material=material, **options)


def test_the_pbd_finite_strain_row_is_labelled_skipped_with_the_reason(benchmark):
    args = benchmark.parse([])
    assert args.material == "neo-hookean"
    skipped = {(name, material): why for name, _, _, material, why in benchmark.rows(args.material, False) if why}
    assert list(skipped) == [("pbd", "neo-hookean")]
    assert "skipped" in skipped["pbd", "neo-hookean"] and "takes only linear" in skipped["pbd", "neo-hookean"]


def test_a_material_that_is_no_finite_strain_material_is_refused(benchmark):
    with pytest.raises(SystemExit):
        benchmark.parse(["--material", "rubber"])
