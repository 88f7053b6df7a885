"""The package's levels hold: the import-linter contract in pyproject.toml (each level imports only from itself and
below), every top-level module placed in a level, and no import circle between any two modules.

The circle check reads the imports that run. An import under ``if TYPE_CHECKING:`` names a class in a type hint only
(a helper module's functions typed with the solver class they serve): it never runs, so it orders nothing and can
close no circle; the levels contract still counts it, so a hint never reaches up a level."""

try:
    import tomllib
except ModuleNotFoundError:     # Python 3.10: import-linter's own TOML reader
    import tomli as tomllib
import subprocess
import sys
from pathlib import Path

import grimp
import pytest

PYPROJECT = Path(__file__).resolve().parents[2] / "pyproject.toml"


@pytest.fixture(scope="module")
def graph():
    return grimp.build_graph("tissuesim", exclude_type_checking_imports=True)


def test_the_levels_contract_is_kept():
    # in a process of its own: import-linter sets up logging for a command line, which would silence the
    # loggers of the tests after it
    check = (f"from importlinter.cli import lint_imports; "
             f"raise SystemExit(lint_imports(config_filename={str(PYPROJECT)!r}, no_cache=True))")
    result = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]


def test_every_top_level_module_has_a_level(graph):
    contract = tomllib.loads(PYPROJECT.read_text())["tool"]["importlinter"]["contracts"][0]
    placed = {name.strip() for layer in contract["layers"] for name in layer.split("|")}
    tops = {module.split(".")[1] for module in graph.modules if module.count(".") >= 1}
    assert tops - placed == set(), "a module outside the levels escapes the contract: add it to pyproject.toml"
    assert placed - tops == set()


def _circles(graph) -> set:
    """Each set of modules that import one another through some chain (a circle), as a sorted tuple."""
    return {tuple(sorted({importer, *chain}))
            for importer in graph.modules for imported in graph.find_modules_directly_imported_by(importer)
            if (chain := graph.find_shortest_chain(importer=imported, imported=importer))}


def test_no_two_modules_import_each_other_through_any_chain(graph):
    assert _circles(graph) == set()


def test_the_circle_check_sees_an_arrow_that_runs_back_up():
    graph = grimp.build_graph("tissuesim", exclude_type_checking_imports=True)
    graph.add_import(importer="tissuesim.errors", imported="tissuesim.cli")    # the lowest module, the highest
    assert any({"tissuesim.errors", "tissuesim.cli"} <= set(circle) for circle in _circles(graph))
